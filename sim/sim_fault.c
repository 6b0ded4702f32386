/*
 * sim_fault.c - the faults a real board meets, injected on request.  Each
 * is an imu-sim option (sim_cli.c); the serial, ADC and run rooms ask here
 * what happens to a byte, a conversion or the power.  Everything random
 * comes from one seeded generator, so a run can be repeated exactly.
 */
#include "sim_fault.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "sim_msg.h"
#include "sim_regbit.h"
#include "avr_eeprom.h"
#include "avr_uart.h"

static const char *const channel_names[ROW_COLUMNS] = {
  "ax", "ay", "az", "gx", "gy", "gz", "temp",
};

/* xorshift64*: a uniform double in [0, 1). */
static double uniform(fault_t *f)
{
  uint64_t x = f->rng ? f->rng : 0x9E3779B97F4A7C15ull;
  x ^= x >> 12;
  x ^= x << 25;
  x ^= x >> 27;
  f->rng = x;
  return (double)((x * 0x2545F4914F6CDD1Dull) >> 11) * 0x1.0p-53;
}

static int chance(fault_t *f, double p)
{
  return p > 0 && uniform(f) < p;
}

int fault_any(const fault_t *f)
{
  return f->loss > 0 || f->flip > 0 || f->no_flow || f->overrun > 0 ||
         f->frame > 0 || f->adc_kind || f->nee || f->power;
}

/* ---- options ------------------------------------------------------------ */

static double parse_num(const char *s, const char *opt, double lo, double hi)
{
  char *end;
  double v = strtod(s, &end);
  if (!*s || *end || !(v >= lo && v <= hi))
    die(EXIT_INPUT, "%s: '%s' is not a number from %g to %g (see --help)", opt,
        s, lo, hi);
  return v;
}

void fault_parse_adc(fault_t *f, const char *arg)
{
  char buf[64];
  snprintf(buf, sizeof buf, "%s", arg);
  char *eq = strchr(buf, '='), *at = strchr(buf, '@');
  if (!eq || (at && at < eq))
    die(EXIT_INPUT, "--adc-fault: '%s' is not CH=CODE|stuck[@ROW] (see --help)",
        arg);
  *eq = 0;
  if (at)
    *at = 0;
  f->adc_ch = -1;
  for (int c = 0; c < ROW_COLUMNS; c++)
    if (!strcmp(buf, channel_names[c]) || (buf[0] == '0' + c && !buf[1]))
      f->adc_ch = c;
  if (f->adc_ch < 0)
    die(EXIT_INPUT,
        "--adc-fault: no channel '%s' (ax ay az gx gy gz temp, or 0..6)", buf);
  if (!strcmp(eq + 1, "stuck")) {
    f->adc_kind = ADC_FAULT_STUCK;
  } else {
    f->adc_kind = ADC_FAULT_CODE;
    f->adc_code = (uint16_t)parse_num(eq + 1, "--adc-fault code", 0, 1023);
  }
  f->adc_row = at ? (uint64_t)parse_num(at + 1, "--adc-fault row", 0, 1e15) : 0;
}

void fault_parse_eeprom(fault_t *f, const char *arg)
{
  char buf[64];
  snprintf(buf, sizeof buf, "%s", arg);
  char *at = strchr(buf, '@'), *colon = strchr(buf, ':');
  if (!at || f->nee == FAULT_EE_MAX)
    die(EXIT_INPUT,
        "--eeprom-flip: '%s' is not ADDR[:MASK]@SEC, or more than %d "
        "(see --help)",
        arg, FAULT_EE_MAX);
  *at = 0;
  if (colon)
    *colon = 0;
  f->ee[f->nee].addr =
      (uint16_t)parse_num(buf, "--eeprom-flip address", 0, 4095);
  f->ee[f->nee].mask = colon ? (uint8_t)strtoul(colon + 1, NULL, 0) : 0x01;
  if (!f->ee[f->nee].mask)
    die(EXIT_INPUT, "--eeprom-flip: mask '%s' flips no bit", colon + 1);
  f->ee[f->nee].t = parse_num(at + 1, "--eeprom-flip time", 0, 1e6);
  f->nee++;
}

void fault_parse_power(fault_t *f, int kind, const char *arg)
{
  const char *opt = kind == POWER_CUT ? "--power-cut" : "--brown-out";
  if (f->power)
    die(EXIT_INPUT, "%s: one power event a run (--power-cut or --brown-out)",
        opt);
  f->power = kind;
  if (!strcmp(arg, "report"))
    f->power_when = WHEN_REPORT;
  else if (!strcmp(arg, "save"))
    f->power_when = WHEN_SAVE;
  else
    f->power_t = parse_num(arg, opt, 0, 1e6);
}

/* ---- what happens ------------------------------------------------------- */

static void schedule(harness_t *h)
{
  fault_t *f = &h->fault;
  double first = INFINITY;
  for (int i = 0; i < f->nee; i++)
    if (!f->ee[i].done && f->ee[i].t < first)
      first = f->ee[i].t;
  if (f->power && !f->power_done && f->power_when == WHEN_TIME &&
      f->power_t < first)
    first = f->power_t;
  if (f->power_due)
    first = 0;
  f->next_at = isinf(first) ? ~(avr_cycle_count_t)0 :
                              (avr_cycle_count_t)(first * h->avr->frequency);
}

/* The firmware sets EEPE: a byte is being written (a `save`). */
static void eecr_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
  harness_t *h = param;
  avr_eeprom_t *ee = (avr_eeprom_t *)find_io(avr, "eeprom", 0);
  (void)addr;
  if (ee && (v >> ee->eepe.bit & 1) && h->fault.power &&
      h->fault.power_when == WHEN_SAVE && !h->fault.power_done) {
    h->fault.power_due = 1; /* cut right after the first byte */
    h->fault.next_at = 0;
  }
}

void fault_connect(harness_t *h)
{
  fault_t *f = &h->fault;
  avr_eeprom_t *ee = (avr_eeprom_t *)find_io(h->avr, "eeprom", 0);
  if (f->power_when == WHEN_SAVE && ee)
    avr_register_io_write(h->avr, ee->eepe.reg, eecr_write, h);
  schedule(h);
}

int fault_host_byte(harness_t *h, uint8_t *c, int *fe)
{
  fault_t *f = &h->fault;
  *fe = 0;
  if (!f->link_on)
    return 1;
  if (chance(f, f->loss)) {
    f->in_lost++;
    return 0;
  }
  if (chance(f, f->flip)) {
    /* one bit of the 10-bit frame: a data bit changes the byte unseen; the
     * stop bit is a framing error; the start bit loses the byte */
    int bit = (int)(uniform(f) * 10);
    f->in_flipped++;
    if (bit == 0) {
      f->in_lost++;
      return 0;
    }
    if (bit == 9) {
      f->in_frame_errors++;
      *fe = 1;
    } else {
      f->in_data_flips++;
      *c ^= (uint8_t)(1u << (bit - 1));
    }
  }
  if (chance(f, f->frame)) {
    f->in_frame_errors++; /* the byte intact, its stop bit read as 0 */
    *fe = 1;
  }
  if (chance(f, f->overrun)) {
    f->overruns_injected++;
    f->overruns++;
    f->dor_pending = 1;
    return 0;
  }
  return 1;
}

/* DOR belongs to the first frame after the lost ones: set once that frame
 * is in simavr's FIFO (set before, simavr would refuse the frame too). */
void fault_host_byte_delivered(harness_t *h)
{
  if (h->fault.dor_pending) {
    h->fault.dor_pending = 0;
    h->fault.dor_events++;
    avr_regbit_setto(h->avr, h->uart->dor, 1);
  }
}

int fault_rx_full(harness_t *h)
{
  /* simavr's FIFO holds the chip's two-frame buffer and the frame in its
   * shift register (simavr raises RXC one byte time after the frame came) */
  avr_uart_t *u = h->uart;
  unsigned unread = (unsigned)(u->input.write - u->input.read) % 64u;
  if (!h->fault.no_flow || unread < 3)
    return 0;
  h->fault.overruns++;
  h->fault.dor_pending = 1;
  return 1;
}

int fault_device_byte(harness_t *h, uint8_t *c)
{
  fault_t *f = &h->fault;
  if (f->power == POWER_NONE || f->power_done || f->power_when != WHEN_REPORT) {
    ;
  } else if (f->prev_dollar && *c == 'L' && h->state != ST_BOOT &&
             h->state != ST_REPORT_H && h->state != ST_REPORT_E) {
    f->power_due = 1; /* a report has begun: cut it midway */
    f->next_at = 0;
  }
  f->prev_dollar = *c == '$';
  if (!f->link_on)
    return 1;
  if (chance(f, f->loss)) {
    f->out_lost++;
    return 0;
  }
  if (chance(f, f->flip)) {
    f->out_flipped++;
    *c ^= (uint8_t)(1u << (int)(uniform(f) * 8));
  }
  return 1;
}

uint16_t fault_adc(harness_t *h, int ch, uint64_t row, uint16_t code)
{
  fault_t *f = &h->fault;
  if (!f->adc_kind || ch != f->adc_ch)
    return code;
  if (row + 1 == f->adc_row || (row == 0 && f->adc_row == 0))
    f->stuck_code = code; /* the value it sticks at */
  if (row < f->adc_row)
    return code;
  f->adc_faulted++;
  return f->adc_kind == ADC_FAULT_CODE ? f->adc_code : f->stuck_code;
}

/* The supply falls and comes back: every register to its reset value, the
 * reset flag that says why (power-on or brown-out). */
static void power_event(harness_t *h)
{
  avr_t *avr = h->avr;
  fault_t *f = &h->fault;
  f->power_done = 1;
  f->power_due = 0;
  f->resets++;
  if (h->verbose)
    fprintf(stderr, PROG ": t=%.6f s: %s\n", sim_time(h),
            f->power == POWER_CUT ? "power cut" : "brown-out");
  avr_reset(avr); /* every I/O register to 0, MCUSR too */
  avr_regbit_set(avr, f->power == POWER_CUT ? avr->reset_flags.porf :
                                              avr->reset_flags.borf);
}

int fault_poll(harness_t *h)
{
  fault_t *f = &h->fault;
  avr_t *avr = h->avr;
  double now = sim_time(h);
  int reset = 0;
  for (int i = 0; i < f->nee; i++) {
    if (f->ee[i].done || f->ee[i].t > now)
      continue;
    uint8_t b;
    avr_eeprom_desc_t d = { .ee = &b, .offset = f->ee[i].addr, .size = 1 };
    avr_ioctl(avr, AVR_IOCTL_EEPROM_GET, &d);
    b ^= f->ee[i].mask;
    d.ee = &b;
    avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d);
    f->ee[i].done = 1;
    f->ee_flipped++;
  }
  if (f->power && !f->power_done &&
      (f->power_due || (f->power_when == WHEN_TIME && f->power_t <= now))) {
    power_event(h);
    reset = 1;
  }
  schedule(h);
  return reset;
}
