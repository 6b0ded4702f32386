/*
 * adc.c - Timer1 CTC tick + interrupt-driven ADC scan into a 3-slot ring.
 * simavr does not emulate the ADC's timer auto-trigger, and the ISR chain
 * is as cheap, so each conversion's interrupt starts the next one.
 */
#include "adc.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <util/atomic.h>

#include "board.h"

#define ADC_RING 3 /* the slot at head is being filled; two wait for main */

static const uint8_t adc_mux[ADC_COLUMNS] PROGMEM = BOARD_ADC_MUX_LIST;

/* A scan packed in 9 bytes: low 8 bits of each code, and the top 2 bits of
 * column i at bits 2i..2i+1 of hi (the ISR shifts them in). */
typedef struct {
  uint8_t lo[ADC_COLUMNS];
  uint16_t hi;
} adc_slot_t;

static volatile adc_slot_t ring[ADC_RING];
static volatile uint8_t ring_head, ring_tail;
static volatile uint8_t scan_col;
/* What the ADC interrupt writes to ADMUX and ADCSRA before anything else:
 * the next column's channel, and ADSC while a column remains (see ADC_vect). */
static volatile uint8_t next_admux, next_adcsra;
#define ADCSRA_IDLE ((1 << ADEN) | (1 << ADIE) | BOARD_ADPS)
#define ADCSRA_START (ADCSRA_IDLE | (1 << ADSC))
/* SCANNING while a scan runs, LIMITED when `start <count>` counts scans:
 * one byte for both, as every byte of SRAM is stack margin. */
static volatile uint8_t flags;
#define SCANNING 0x01u
#define LIMITED  0x02u
static volatile uint32_t budget; /* scans left when limited */
static volatile uint8_t isr_drops; /* counted by the ISRs, 8 bits to keep them small */
static uint32_t drops;             /* folded in by the main loop */

static uint8_t ring_next(uint8_t i)
{
  return (uint8_t)(i + 1u == ADC_RING ? 0u : i + 1u);
}

void adc_init(void)
{
  BOARD_PROBE_INIT();
  ADMUX = BOARD_ADMUX_REF;
  ADCSRA = ADCSRA_IDLE;
  DIDR0 = 0x3F; /* ADC0..5 are analog only: no digital input buffers */
  TCCR1A = 0;
  TCCR1B = (1 << WGM12); /* CTC on OCR1A, clock off until adc_start */
  adc_set_rate(100);
}

void adc_set_rate(uint16_t hz)
{
  OCR1A = (uint16_t)(F_CPU / BOARD_TIMER1_PRESCALER / hz - 1u);
}

uint16_t adc_rate(void)
{
  /* From the timer itself: exact for every supported rate at 10 MHz. */
  return (uint16_t)((F_CPU / BOARD_TIMER1_PRESCALER + (OCR1A + 1ul) / 2u) / (OCR1A + 1ul));
}

void adc_start(uint8_t lim, uint32_t count)
{
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    flags = (uint8_t)((flags & SCANNING) | (lim ? LIMITED : 0u));
    budget = count;
    TCNT1 = 0;
    TIFR1 = (1 << OCF1A);
    TCCR1B = (1 << WGM12) | BOARD_TIMER1_CS;
    TIMSK1 = (1 << OCIE1A);
  }
}

void adc_stop(void)
{
  TIMSK1 = 0;
  TCCR1B = (1 << WGM12);
  while (flags & SCANNING)
    ;
}

uint8_t adc_running(void)
{
  return (TIMSK1 & (1 << OCIE1A)) != 0;
}

/* Move the ISRs' count into the 32-bit total (main loop only). */
static void fold_drops(void)
{
  uint8_t d;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    d = isr_drops;
    isr_drops = 0;
  }
  drops = drops + d < drops ? 0xFFFFFFFFul : drops + d;
}

uint8_t adc_pending(void)
{
  uint8_t h = ring_head, t = ring_tail;
  return (uint8_t)(h >= t ? h - t : h + ADC_RING - t);
}

uint8_t adc_peek(uint16_t code[ADC_COLUMNS])
{
  uint8_t i;
  if (ring_tail == ring_head)
    return 0;
  for (i = 0; i < ADC_COLUMNS; i++)
    code[i] = adc_oldest(i);
  return 1;
}

uint16_t adc_oldest(uint8_t col)
{
  /* The top bits from the right byte of hi, shifted at most 6 places: the
   * AVR shifts one bit per instruction, and this runs 7 times a set. */
  volatile adc_slot_t *s = &ring[ring_tail];
  uint8_t b = col < 4u ? (uint8_t)s->hi : (uint8_t)(s->hi >> 8);
  switch (col & 3u) {
  case 1: b >>= 2; break;
  case 2: b >>= 4; break;
  case 3: b >>= 6; break;
  default: break;
  }
  return (uint16_t)(s->lo[col] | ((uint16_t)(b & 3u) << 8));
}

uint8_t adc_peek_packed(uint8_t out[ADC_PACKED_BYTES])
{
  uint8_t t = ring_tail, i;
  if (t == ring_head)
    return 0;
  for (i = 0; i < ADC_COLUMNS; i++)
    out[i] = ring[t].lo[i];
  out[ADC_COLUMNS] = (uint8_t)ring[t].hi;
  out[ADC_COLUMNS + 1] = (uint8_t)(ring[t].hi >> 8);
  return 1;
}

void adc_discard(void)
{
  if (isr_drops)
    fold_drops(); /* once per set: the ISRs' 8-bit count never saturates */
  if (ring_tail != ring_head)
    ring_tail = ring_next(ring_tail);
}

void adc_flush(void)
{
  ring_tail = ring_head;
}

uint32_t adc_drops(void)
{
  fold_drops();
  return drops;
}

void adc_clear_drops(void)
{
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { isr_drops = 0; }
  drops = 0;
}

static inline __attribute__((always_inline)) void drop_one(void)
{
  if (isr_drops != 0xFF)
    isr_drops++;
}

void adc_count_drop(void)
{
  fold_drops();
  if (drops != 0xFFFFFFFFul)
    drops++;
}

ISR(TIMER1_COMPA_vect)
{
  if (flags & SCANNING) {
    drop_one(); /* previous scan unfinished: the rate outruns the ADC */
    return;
  }
  if (flags & LIMITED) {
    if (budget == 0) {
      TIMSK1 = 0; /* done: the count asked for by `start <count>` */
      TCCR1B = (1 << WGM12);
      return;
    }
    budget--;
  }
  flags |= SCANNING;
  scan_col = 0;
  ring[ring_head].hi = 0;
  ADMUX = BOARD_ADMUX_REF | pgm_read_byte(&adc_mux[0]);
  ADCSRA = ADCSRA_START;
  next_admux = BOARD_ADMUX_REF | pgm_read_byte(&adc_mux[1]);
  next_adcsra = ADCSRA_START;
}

/* The ADC interrupt starts the next conversion first thing: a conversion
 * started by ADSC begins at the next ADC clock edge, so an ADSC written
 * within one ADC clock (64 cycles) of ADIF costs 14 ADC clocks per
 * conversion, a later one 15 (with the compiler's 15-register prologue in
 * front it came 109 cycles late).  Its first instructions, before any
 * prologue, copy two prepared bytes to ADMUX (the channel may change once
 * ADIF is set) and ADCSRA (ADSC, or not after the last column), touching
 * neither SREG nor any register but r24; then the ISR proper below. */
ISR(ADC_vect, ISR_NAKED)
{
  __asm__ __volatile__(
    "push r24\n\t"
    "lds r24, %[mux]\n\t"
    "sts %[admux], r24\n\t"
    "lds r24, %[csra]\n\t"
    "sts %[adcsra], r24\n\t"
    "pop r24\n\t"
    "jmp __vector_adc_result\n\t"
    :
    : [mux] "i"(&next_admux), [csra] "i"(&next_adcsra),
      [admux] "i"(_SFR_MEM_ADDR(ADMUX)), [adcsra] "i"(_SFR_MEM_ADDR(ADCSRA)));
}

/* The rest of the ADC interrupt: an ordinary ISR body ("__vector" in its
 * name, so that avr-gcc accepts it as one), entered by the jump above. */
void __vector_adc_result(void) __attribute__((signal, used, externally_visible));
void __vector_adc_result(void)
{
  uint8_t col = scan_col, h = ring_head;
  uint8_t lo, hi;
  BOARD_PROBE_ISR_ON();
  lo = ADCL; /* ADCL first: reading it locks ADCH until ADCH is read */
  hi = ADCH; /* the result stays until the conversion just started ends */
  ring[h].lo[col] = lo;
  ring[h].hi = (uint16_t)((ring[h].hi >> 2) | ((uint16_t)hi << 12));
  if (++col < ADC_COLUMNS) {
    scan_col = col;
    if (col + 1u < ADC_COLUMNS)
      next_admux = BOARD_ADMUX_REF | pgm_read_byte(&adc_mux[col + 1u]);
    else
      next_adcsra = ADCSRA_IDLE; /* the last column: start nothing after it */
  } else {
    uint8_t next = ring_next(h);
    if (next == ring_tail)
      drop_one(); /* main loop behind: this set is lost, and counted */
    else
      ring_head = next;
    flags &= (uint8_t)~SCANNING;
  }
  BOARD_PROBE_ISR_OFF();
}
