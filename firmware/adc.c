/*
 * adc.c - Timer1 CTC tick + ADC scan into a 3-slot ring.  The tick starts
 * a scan's first conversion; the ADC runs the other six itself, back to
 * back (auto-trigger, free running: each starts as the previous one ends),
 * so a scan lasts 7 x 13 ADC clocks whatever other interrupts delay the
 * ADC's: its interrupt only reads a result and sets the channel after next.
 */
#include "adc.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <util/atomic.h>

#include "board.h"
#include "vocab.h"

/* The slot at head is being filled; the others wait for the main loop.
 * Three on the 1 KB ATmega168; on parts with 2 KB (ATmega328P, whose
 * 20-level engine costs more a set) five, so that 1500 Hz keeps up. */
#if RAMEND > 0x4FF
#  define ADC_RING 5
#else
#  define ADC_RING 3
#endif

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
#define ADCSRA_IDLE ((1 << ADEN) | (1 << ADIE) | BOARD_ADPS)
/* A scan's first conversion, the next ones started by the ADC itself
 * (ADCSRB's ADTS = 0: free running) until the interrupt clears ADATE. */
#define ADCSRA_SCAN (ADCSRA_IDLE | (1 << ADSC) | (1 << ADATE))
/* SCANNING while a scan runs, LIMITED when `start <count>` counts scans,
 * and the dither phase: bits of board.h's BOARD_FLAGS (no SRAM). */
#define adc_flags BOARD_FLAGS
#define SCANNING BOARD_FLAG_SCANNING
#define LIMITED BOARD_FLAG_LIMITED
#define DITHER BOARD_FLAG_DITHER
static volatile uint32_t budget;   /* scans left when limited */
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
  /* The first conversion after ADEN takes 25 ADC clocks, not 13: done
   * here (0.16 ms, interrupts still off), so that no scan ever starts with
   * it (at 1500 Hz the first scan would outlast its period). */
  ADCSRA = (1 << ADEN) | (1 << ADSC) | BOARD_ADPS;
  while (ADCSRA & (1 << ADSC))
    ;
  ADCSRA = ADCSRA_IDLE | (1 << ADIF); /* ADIF: cleared by writing 1 */
  DIDR0 = 0x3F;                       /* ADC0..5 are analog only: no digital input buffers */
  TCCR1A = 0;
  TCCR1B = (1 << WGM12); /* CTC on OCR1A, clock off until adc_start */
  adc_set_rate(100);
}

/* 1500 Hz has no exact Timer1 period (10^7 / 1500 = 6666.67 CPU cycles):
 * it runs at prescaler 1 with OCR1A dithered over three periods, 6667,
 * 6667 and 6666 cycles at 10 MHz.  The mean is exact, and each tick is at
 * most one CPU cycle (0.1 us) off the ideal grid, far less than the up to
 * one ADC clock (6.4 us) by which the ADC's clock edge already moves every
 * conversion's start (docs/firmware.md, Timing).  The dither's state is
 * two bits of BOARD_FLAGS, an I/O register (no SRAM): 0 for an exact
 * rate, else the phase 3, 2, 1 of the period in progress. */
#define DITHER_HZ 1500u
#define DITHER_TOP (F_CPU / DITHER_HZ - 1u)                             /* OCR1A of a short period */
#define DITHER_LONG ((uint8_t)((F_CPU % DITHER_HZ) / (DITHER_HZ / 3u))) /* long periods in three */
#if (3ull * F_CPU) % DITHER_HZ != 0 || F_CPU / DITHER_HZ > 65535u
#  error "1500 Hz needs F_CPU / 1500 to be a whole number of thirds below 65536"
#endif
#if (F_CPU / BOARD_TIMER1_PRESCALER) % DITHER_HZ == 0
#  error "1500 Hz has an exact period at this F_CPU: no dither needed (adc.c)"
#endif

/* OCR1A of each rate in vocab_rates' order, worked out by the compiler
 * (no division at run time; 1500 Hz's entry is not used: the dither). */
#define OCR_ITEM(a, hz) (uint16_t)(F_CPU / BOARD_TIMER1_PRESCALER / (hz)-1u),
static const uint16_t rate_ocr[] PROGMEM = {VOCAB_RATES(OCR_ITEM, 0)};

void adc_set_rate(uint16_t hz)
{
  /* Stopped: no tick rewrites the flags meanwhile. */
  if (hz == DITHER_HZ) { /* the only rate in the list without an exact period */
    adc_flags |= DITHER; /* phase 3 */
    OCR1A = (uint16_t)(DITHER_TOP + (3u <= DITHER_LONG));
  } else {
    adc_flags &= (uint8_t)~DITHER;
    OCR1A = pgm_read_word(&rate_ocr[vocab_rate_index(hz)]); /* hz: one of the list */
  }
}

uint16_t adc_rate(void)
{
  const uint16_t *p = rate_ocr;
  uint16_t ocr = OCR1A;
  if (adc_flags & DITHER)
    return DITHER_HZ;
  /* From the timer itself: the rate whose period it counts (always one of
   * the list: adc_set_rate wrote it; the last one if not). */
  while (pgm_read_word(p) != ocr && p < rate_ocr + VOCAB_RATE_COUNT - 1)
    p++;
  return pgm_read_word(&vocab_rates[p - rate_ocr]);
}

void adc_start(uint8_t lim, uint32_t count)
{
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    if (lim)
      adc_flags |= LIMITED;
    else
      adc_flags &= (uint8_t)~LIMITED;
    budget = count;
    TCNT1 = 0;
    TIFR1 = (1 << OCF1A);
    if (!lim || count) { /* else nothing to take: the timer stays off */
      TCCR1B = (uint8_t)((1 << WGM12) | ((adc_flags & DITHER) ? (1 << CS10) : BOARD_TIMER1_CS));
      TIMSK1 = (1 << OCIE1A);
    }
  }
}

uint32_t adc_remaining(void)
{
  uint32_t r;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    r = (adc_flags & LIMITED) ? budget : ADC_UNLIMITED;
  }
  return r;
}

void adc_limit(uint32_t total)
{
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    uint8_t waiting = adc_pending();
    adc_flags |= LIMITED;
    budget = total > waiting ? total - waiting : 0;
    if (!budget) { /* enough taken: the tick stops (a scan under way lands) */
      TIMSK1 = 0;
      TCCR1B = (1 << WGM12);
    }
  }
}

void adc_stop(void)
{
  TIMSK1 = 0;
  TCCR1B = (1 << WGM12);
  while (adc_flags & SCANNING)
    ;
}

uint8_t adc_running(void)
{
  /* The tick stops as the last scan of a `start <count>` begins; that
   * scan still counts as running until it lands in the ring. */
  return (TIMSK1 & (1 << OCIE1A)) || (adc_flags & SCANNING);
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
   * AVR shifts one bit per instruction, and this runs 7 times a set.  The
   * slot's address is worked out once (the ring is volatile). */
  const volatile uint8_t *s = ring[ring_tail].lo;
  uint8_t b = s[col < 4u ? ADC_COLUMNS : ADC_COLUMNS + 1];
  switch (col & 3u) {
  case 1: b >>= 2; break;
  case 2: b >>= 4; break;
  case 3: b >>= 6; break;
  default: break;
  }
  return (uint16_t)(s[col] | ((uint16_t)(b & 3u) << 8));
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
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    isr_drops = 0;
  }
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
  uint8_t g, phase;
  if (adc_flags & SCANNING) {
    drop_one(); /* previous scan unfinished: the rate outruns the ADC */
  } else {      /* the scan starts first thing */
    ADMUX = BOARD_ADMUX_REF | pgm_read_byte(&adc_mux[0]);
    ADCSRA = ADCSRA_SCAN;
    /* No change on the chip (ADTS is 0 already); simavr sets its trigger
     * mode from ADCSRA as it was before a write, so it needs a second one. */
    ADCSRB = 0;
    /* `start <count>`: the tick stops as its last scan begins (adc_start
     * and adc_limit never leave it running with nothing left). */
    if ((adc_flags & LIMITED) && --budget == 0) {
      TIMSK1 = 0;
      TCCR1B = (1 << WGM12);
    }
    adc_flags |= SCANNING;
    scan_col = 0;
    ring[ring_head].hi = 0;
    /* The second conversion takes the channel set when the first ends: it
     * may change one ADC clock after ADSC (the first one's channel is then
     * locked; datasheet, "Changing Channel or Reference Selection"). */
    __builtin_avr_delay_cycles(BOARD_ADC_PRESCALER);
    ADMUX = BOARD_ADMUX_REF | pgm_read_byte(&adc_mux[1]);
  }
  /* Dithered: the period under way (its count still far from OCR1A) gets
   * the next phase's length. */
  g = adc_flags;
  phase = g;
  phase &= DITHER;
  if (phase) {
    if (--phase == 0)
      phase = 3;
    adc_flags = (uint8_t)((g & (uint8_t)~DITHER) | phase);
    OCR1A = (uint16_t)(DITHER_TOP + (phase <= DITHER_LONG));
  }
}

/* The ADC interrupt: conversion c of the scan has ended and the ADC has
 * started c + 1 by itself, on the channel it found set (the tick set the
 * first two).  It stores c's result, sets the channel of c + 2, or after
 * c = 5 clears ADATE so that c + 1 = 6 is the last, and ends the scan
 * after c = 6.  It has all of a conversion (13 ADC clocks, 832 cycles) to
 * do so, so its latency (other interrupts first) no longer lengthens the
 * scan.  It must come within that time, though: the next start is ADIF's
 * rising edge, which taking the interrupt clears (nothing holds interrupts
 * off nearly that long: the longest, the tick's, is 205 cycles).  The
 * channel is written at least one ADC clock after the next conversion
 * began (about 80 cycles after the vector; the datasheet's rule, as in the
 * tick).  In assembly with 6 registers (the compiler's version
 * pushed 15, on top of the main loop's deepest stack, where every byte
 * counts on the ATmega168); the same work as this C:
 *
 *   slot = &ring[ring_head];  slot->lo[scan_col] = ADCL;
 *   slot->hi = (slot->hi >> 2) | (ADCH << 12);     top 2 bits, column by column
 *   if (++scan_col < ADC_COLUMNS) {
 *     if (scan_col + 1 < ADC_COLUMNS) ADMUX = REF | adc_mux[scan_col + 1];
 *     else ADCSRA = ADCSRA_IDLE;                     no conversion after the last
 *   } else {                                        scan done
 *     next = ring_next(ring_head);
 *     if (next == ring_tail) drop_one(); else ring_head = next;
 *     flags &= ~SCANNING;
 *   }
 */
#if BOARD_PROBES
#  define ADC_ISR_PROBE_ON "sbi %[portb], 1\n\t"
#  define ADC_ISR_PROBE_OFF "cbi %[portb], 1\n\t"
#else
#  define ADC_ISR_PROBE_ON ""
#  define ADC_ISR_PROBE_OFF ""
#endif
ISR(ADC_vect, ISR_NAKED)
{
  __asm__ __volatile__(
      "push r24\n\t"
      "in r24, __SREG__\n\t"
      "push r24\n\t"
      "push r25\n\t"
      "push r26\n\t"
      "push r27\n\t"
      "push r30\n\t"
      "push r31\n\t" ADC_ISR_PROBE_ON
      /* Z = slot = ring + 9 * ring_head, X = &slot->lo[scan_col] */
      "lds r24, %[head]\n\t"
      "mov r25, r24\n\t"
      "lsl r25\n\t"
      "lsl r25\n\t"
      "lsl r25\n\t"
      "add r25, r24\n\t"
      "ldi r30, lo8(%[ring])\n\t"
      "ldi r31, hi8(%[ring])\n\t"
      "add r30, r25\n\t"
      "ldi r25, 0\n\t"
      "adc r31, r25\n\t"
      "lds r24, %[col]\n\t"
      "movw r26, r30\n\t"
      "add r26, r24\n\t"
      "adc r27, r25\n\t"
      "lds r25, %[adcl]\n\t" /* ADCL first: reading it locks ADCH until ADCH is read */
      "st X, r25\n\t"
      "lds r26, %[adch]\n\t" /* r26: the code's top 2 bits */
      /* hi word >> 2, with the top bits in at bits 12..13 */
      "ldd r25, Z+%[hilo]\n\t"
      "lsr r25\n\t"
      "lsr r25\n\t"
      "ldd r27, Z+%[hilo]+1\n\t"
      "mov r24, r27\n\t"
      "andi r24, 3\n\t"
      "swap r24\n\t"
      "lsl r24\n\t"
      "lsl r24\n\t"
      "or r25, r24\n\t"
      "std Z+%[hilo], r25\n\t"
      "lsr r27\n\t"
      "lsr r27\n\t"
      "swap r26\n\t"
      "or r27, r26\n\t"
      "std Z+%[hilo]+1, r27\n\t"
      /* the next column */
      "lds r24, %[col]\n\t"
      "inc r24\n\t"
      "cpi r24, %[ncol]\n\t"
      "brsh 3f\n\t"
      "sts %[col], r24\n\t"
      "cpi r24, %[ncol]-1\n\t"
      "brsh 2f\n\t"
      "mov r30, r24\n\t" /* Z = &adc_mux[1] + r24 */
      "ldi r31, 0\n\t"
      "subi r30, lo8(-(%[mux1]))\n\t"
      "sbci r31, hi8(-(%[mux1]))\n\t"
      "lpm r25, Z\n\t"
      "ori r25, %[ref]\n\t"
      "sts %[admux], r25\n\t"
      "rjmp 9f\n"
      "2:\n\t"
      "ldi r25, %[idle]\n\t"
      "sts %[adcsra], r25\n\t"
      "rjmp 9f\n"
      /* scan done: into the ring, or counted as dropped */
      "3:\n\t"
      "lds r24, %[head]\n\t"
      "inc r24\n\t"
      "cpi r24, %[nring]\n\t"
      "brne 4f\n\t"
      "ldi r24, 0\n"
      "4:\n\t"
      "lds r25, %[tail]\n\t"
      "cp r24, r25\n\t"
      "brne 5f\n\t"
      "lds r25, %[drops]\n\t"
      "cpi r25, 0xFF\n\t"
      "breq 6f\n\t"
      "inc r25\n\t"
      "sts %[drops], r25\n\t"
      "rjmp 6f\n"
      "5:\n\t"
      "sts %[head], r24\n"
      "6:\n\t"
      "cbi %[flagreg], %[scanbit]\n"
      "9:\n\t" ADC_ISR_PROBE_OFF "pop r31\n\t"
      "pop r30\n\t"
      "pop r27\n\t"
      "pop r26\n\t"
      "pop r25\n\t"
      "pop r24\n\t"
      "out __SREG__, r24\n\t"
      "pop r24\n\t"
      "reti\n\t"
      :
      : [admux] "i"(_SFR_MEM_ADDR(ADMUX)), [adcsra] "i"(_SFR_MEM_ADDR(ADCSRA)),
        [adcl] "i"(_SFR_MEM_ADDR(ADCL)), [adch] "i"(_SFR_MEM_ADDR(ADCH)),
#if BOARD_PROBES
        [portb] "I"(_SFR_IO_ADDR(PORTB)),
#endif
        [head] "i"(&ring_head), [tail] "i"(&ring_tail), [col] "i"(&scan_col), [ring] "i"(ring),
        [hilo] "n"(ADC_COLUMNS), [ncol] "n"(ADC_COLUMNS), [nring] "n"(ADC_RING), [mux1] "i"(&adc_mux[1]),
        [ref] "n"(BOARD_ADMUX_REF), [idle] "n"(ADCSRA_IDLE), [drops] "i"(&isr_drops),
        [flagreg] "I"(_SFR_IO_ADDR(BOARD_FLAGS)), [scanbit] "I"(__builtin_ctz(SCANNING)));
}
