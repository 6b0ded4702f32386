/*
 * fake_device.c - the fakes behind fixture.h: uart.h, adc.h, the EEPROM,
 * the I/O registers, and the clock that drives them.  Only the hardware is
 * fake; every firmware module linked beside this file is the real one.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "adc.h"
#include "clock.h"
#include "console.h"
#include "control.h"
#include "fixture.h"
#include "loop.h"
#include "reset.h"
#include "sample.h"
#include "switchboard.h"
#include "uart.h"
#include <avr/eeprom.h>

volatile uint8_t fake_ddrb, fake_portb, fake_ddrd, fake_portd, fake_gpior0, fake_gpior2;
uint8_t fake_eeprom[E2END + 1];

char fx_out[1 << 20];
size_t fx_out_len;
uint32_t fx_sets_made;

static uint64_t now_ns;
#define BYTE_NS (10ull * 1000000000ull / BAUD)

/* ---- UART: TX ring of UART_STEP_MAX + 1 slots (one always empty), RX
 * ring of 8 with the device's gap marking ---- */
#define TX_ROOM UART_STEP_MAX
static unsigned tx_fill;
static uint64_t tx_next_ns;
#define RX_SIZE 8
static uint8_t rx_buf[RX_SIZE];
static unsigned rx_head, rx_tail;
static int rx_gap = -1; /* the slot a gap precedes, -1: none */
static int rx_gap_why;  /* UART_READ_OVERRUN | UART_READ_FRAME | UART_READ_RING */
static int rx_gap_more; /* another gap came before it: every byte up to it follows a gap */
static char *rx_queue;
static char *rx_lostq; /* 1: this queued byte is lost in the USART (overrun); 2: it has FE set */
static size_t rx_queue_len, rx_queue_pos;
static uint64_t rx_next_ns;

void uart_init(void) {}

void uart_write(uint8_t c)
{
  if (tx_fill >= TX_ROOM) {
    fprintf(stderr, "firmware wrote into a full TX ring\n");
    abort();
  }
  if (fx_out_len + 1 >= sizeof fx_out) {
    fprintf(stderr, "output capture full\n");
    abort();
  }
  if (tx_fill == 0 && tx_next_ns < now_ns)
    tx_next_ns = now_ns + BYTE_NS;
  tx_fill++;
  fx_out[fx_out_len++] = (char)c;
  fx_out[fx_out_len] = 0;
}

uint8_t uart_tx_room(void)
{
  return (uint8_t)(TX_ROOM - tx_fill);
}

int16_t uart_read(void)
{
  int16_t gap = 0;
  uint8_t c;
  if ((int)rx_tail == rx_gap) {
    gap = (int16_t)(UART_READ_GAP | rx_gap_why);
    rx_gap = -1;
    rx_gap_why = rx_gap_more = 0;
  } else if (rx_gap_more) {
    gap = UART_READ_GAP;
  }
  if (rx_head == rx_tail)
    return gap ? (int16_t)(gap | UART_READ_EMPTY) : -1;
  c = rx_buf[rx_tail];
  rx_tail = (rx_tail + 1) % RX_SIZE;
  return (int16_t)(gap | c);
}

uint8_t uart_rx_pending(void)
{
  return rx_head != rx_tail;
}

/* A gap just before slot h (uart.c's marking, with its reasons). */
static void mark_gap(int why)
{
  if (rx_gap >= 0 && rx_gap != (int)rx_head)
    rx_gap_more = 1;
  rx_gap = (int)rx_head;
  rx_gap_why |= why;
}

static int dor; /* bytes were lost in the USART: the next byte has DOR set */

static void rx_byte(uint8_t c, int lost)
{
  unsigned next = (rx_head + 1) % RX_SIZE;
  if (lost == 1) {
    dor = 1;
    return;
  }
  if (dor) { /* uart.c's ISR reads DOR with the byte */
    dor = 0;
    mark_gap(UART_READ_OVERRUN);
  }
  if (lost == 2) { /* FE: the byte is thrown away, the next one stored follows a gap */
    mark_gap(UART_READ_FRAME);
    return;
  }
  if (next == rx_tail) {
    mark_gap(UART_READ_RING);
    return;
  }
  rx_buf[rx_head] = c;
  rx_head = next;
}

static void queue(const char *bytes, size_t n, int lost)
{
  rx_queue = realloc(rx_queue, rx_queue_len + n);
  rx_lostq = realloc(rx_lostq, rx_queue_len + n);
  memcpy(rx_queue + rx_queue_len, bytes, n);
  memset(rx_lostq + rx_queue_len, lost, n);
  rx_queue_len += n;
  if (rx_next_ns < now_ns)
    rx_next_ns = now_ns + BYTE_NS;
}

void fx_send(const char *bytes, size_t n)
{
  queue(bytes, n, 0);
}

void fx_send_overrun(const char *bytes, size_t n)
{
  queue(bytes, n, 1);
}

void fx_send_frame_error(const char *bytes, size_t n)
{
  queue(bytes, n, 2);
}

void fx_send_str(const char *s)
{
  fx_send(s, strlen(s));
}

/* ---- ADC: ticks at the rate; a set lands in a ring of three slots, two
 * of which may wait for the main loop ---- */
#define ADC_SLOTS 3
static uint16_t ring[ADC_SLOTS][ADC_COLUMNS];
static unsigned ring_head, ring_tail;
static uint16_t rate_hz = 100;
static int running, limited;
static uint32_t budget, drops;
static uint64_t next_tick_ns;

uint16_t fx_code(uint32_t i, uint8_t col)
{
  /* A deterministic pattern that uses all 10 bits and differs by column. */
  uint32_t x = i * 2654435761u + col * 40503u;
  return (uint16_t)((x >> 7) % 1024u);
}

void adc_init(void) {}
void adc_set_rate(uint16_t hz)
{
  rate_hz = hz;
}
uint16_t adc_rate(void)
{
  return rate_hz;
}

void adc_start(uint8_t lim, uint32_t count)
{
  limited = lim;
  budget = count;
  running = !lim || count; /* like adc.c: nothing to take, no tick */
  next_tick_ns = now_ns + 1000000000ull / rate_hz;
}

void adc_stop(void)
{
  running = 0;
}

uint32_t adc_remaining(void)
{
  return limited ? budget : ADC_UNLIMITED;
}

void adc_limit(uint32_t total)
{
  uint32_t waiting = adc_pending();
  limited = 1;
  budget = total > waiting ? total - waiting : 0;
  if (!budget)
    running = 0;
}
uint8_t adc_running(void)
{
  return (uint8_t)running;
}

uint8_t adc_pending(void)
{
  return (uint8_t)((ring_head + ADC_SLOTS - ring_tail) % ADC_SLOTS);
}

uint16_t adc_oldest(uint8_t col)
{
  return ring[ring_tail][col];
}

uint8_t adc_peek(uint16_t code[ADC_COLUMNS])
{
  if (!adc_pending())
    return 0;
  memcpy(code, ring[ring_tail], sizeof ring[0]);
  return 1;
}

uint8_t adc_peek_packed(uint8_t out[ADC_PACKED_BYTES])
{
  uint16_t hi = 0;
  uint8_t i;
  if (!adc_pending())
    return 0;
  for (i = 0; i < ADC_COLUMNS; i++) {
    out[i] = (uint8_t)ring[ring_tail][i];
    hi |= (uint16_t)((ring[ring_tail][i] >> 8) << (2 * i));
  }
  out[ADC_COLUMNS] = (uint8_t)hi;
  out[ADC_COLUMNS + 1] = (uint8_t)(hi >> 8);
  return 1;
}

void adc_discard(void)
{
  if (adc_pending())
    ring_tail = (ring_tail + 1) % ADC_SLOTS;
}

void adc_flush(void)
{
  ring_tail = ring_head;
}
uint32_t adc_drops(void)
{
  return drops;
}
void adc_clear_drops(void)
{
  drops = 0;
}
void adc_count_drop(void)
{
  drops++;
}

static void adc_tick(void)
{
  unsigned next = (ring_head + 1) % ADC_SLOTS;
  uint8_t col;
  /* Like adc.c: the tick that takes the last set of a limited run stops
   * (the fake's scan lands at once, so sampling has ended). */
  if (limited && --budget == 0)
    running = 0;
  for (col = 0; col < ADC_COLUMNS; col++)
    ring[ring_head][col] = fx_code(fx_sets_made, col);
  fx_sets_made++;
  if (next == ring_tail)
    drops++; /* the main loop is behind: the set is lost, and counted */
  else
    ring_head = next;
}

/* ---- EEPROM: blank at power-up unless a test wrote it first ---- */
void eeprom_read_block(void *dst, const void *src, size_t n)
{
  memcpy(dst, fake_eeprom + (uintptr_t)src, n);
}

void eeprom_update_byte(uint8_t *addr, uint8_t value)
{
  fake_eeprom[(uintptr_t)addr] = value;
}

int eeprom_is_ready(void)
{
  return 1;
}

/* ---- clock and loop ---- */
uint64_t fx_now_us(void)
{
  return now_ns / 1000u;
}

/* clock.h: Timer0's overflows, one every CLOCK_TICK_CYCLES CPU cycles
 * (free-running: a restart does not move its phase), counted since the
 * last clock_restart(), at most 255. */
static uint64_t ticks_at_restart;

static uint64_t ticks_now(void)
{
  return now_ns / (CLOCK_TICK_CYCLES * 1000000000ull / F_CPU);
}

uint8_t clock_ticks(void)
{
  uint64_t n = ticks_now() - ticks_at_restart;
  return (uint8_t)(n > 255 ? 255 : n);
}

void clock_restart(void)
{
  ticks_at_restart = ticks_now();
}

static void advance_to(uint64_t t)
{
  now_ns = t;
  while (tx_fill && tx_next_ns <= now_ns) {
    tx_fill--;
    tx_next_ns += BYTE_NS;
  }
  while (rx_queue_pos < rx_queue_len && rx_next_ns <= now_ns) {
    rx_byte((uint8_t)rx_queue[rx_queue_pos], rx_lostq[rx_queue_pos]);
    rx_queue_pos++;
    rx_next_ns += BYTE_NS;
  }
  while (running && next_tick_ns <= now_ns) {
    adc_tick();
    next_tick_ns += 1000000000ull / rate_hz;
  }
}

/* reset.h's cause of the last reset, as fx_boot() was given it. */
static uint8_t fake_cause;
uint8_t reset_cause(void)
{
  return fake_cause;
}

void fx_boot(uint8_t mcusr)
{
  static int erased;
  if (!erased) {
    /* blank unless the test filled it before booting */
    size_t i;
    int any = 0;
    for (i = 0; i <= E2END; i++)
      any |= fake_eeprom[i];
    if (!any)
      memset(fake_eeprom, 0xFF, sizeof fake_eeprom);
    erased = 1;
  }
  /* main.c's start-up, in its order */
  fake_cause = mcusr;
  switchboard_init();
  uart_init();
  adc_init();
  control_init();
  switchboard_boot();
  adc_start(0, 0);
}

void fx_run_us(uint64_t us)
{
  uint64_t end = now_ns + us * 1000u;
  while (now_ns < end) {
    advance_to(now_ns + 20000u); /* one loop pass: 20 us */
    loop_pass();                 /* main.c's loop body */
  }
}

long fx_find_line(const char *prefix, unsigned n, char *body, size_t body_size, unsigned *crc)
{
  size_t plen = strlen(prefix);
  const char *p = fx_out;
  while ((p = strchr(p, '$')) != NULL) {
    const char *star = strchr(p, '*');
    const char *nl = strchr(p, '\n');
    if (star && nl && star < nl && strncmp(p + 1, prefix, plen) == 0 && n-- == 0) {
      size_t len = (size_t)(star - p - 1);
      if (len >= body_size)
        len = body_size - 1;
      memcpy(body, p + 1, len);
      body[len] = 0;
      if (crc)
        *crc = (unsigned)strtoul(star + 1, NULL, 16);
      return p - fx_out;
    }
    p++;
  }
  return -1;
}

unsigned fx_count_lines(const char *prefix)
{
  unsigned n = 0;
  char body[512];
  while (fx_find_line(prefix, n, body, sizeof body, NULL) >= 0)
    n++;
  return n;
}
