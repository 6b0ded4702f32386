/*
 * report.c - writes protocol lines.  Each line reads the values it prints
 * right before printing them: uart_write lets the main loop feed the engine
 * while the line drains, so a row is a consistent snapshot of its own.
 */
#include "report.h"

#include <avr/io.h>
#include <avr/pgmspace.h>

#include "adc.h"
#include "allan.h"
#include "config.h"
#include "fmt.h"
#include "proto.h"
#include "sample.h"

static const char channel_names[] PROGMEM = "axayazgxgygz";
static uint8_t reset_cause;
static uint16_t report_seq;

void report_init(uint8_t cause)
{
  reset_cause = cause;
}

static void put_channel(uint8_t ch)
{
  proto_putc((char)pgm_read_byte(&channel_names[2 * ch]));
  proto_putc((char)pgm_read_byte(&channel_names[2 * ch + 1]));
}

static void put_seq(char type)
{
  proto_begin();
  proto_putc(type);
  proto_putc(',');
  proto_u32(report_seq);
  proto_putc(',');
}

static void put_reset_cause(void)
{
  static const char names[] PROGMEM = "por\0ext\0bor\0wdt\0";
  uint8_t bit, any = 0;
  proto_puts_P(PSTR("reset="));
  for (bit = 0; bit < 4; bit++) {
    if (reset_cause & (1u << bit)) { /* PORF EXTRF BORF WDRF */
      if (any)
        proto_putc('+');
      proto_puts_P(names + 4 * bit);
      any = 1;
    }
  }
  if (!any)
    proto_puts_P(PSTR("none"));
}

static void put_identity(void)
{
  proto_puts_P(PSTR("proto="));
  proto_u32(PROTO_VERSION);
  proto_puts_P(PSTR(",fw=" FW_VERSION ",mcu=" FW_MCU_NAME));
}

void report_boot(void)
{
  proto_begin();
  proto_puts_P(PSTR("B,"));
  put_identity();
  proto_putc(',');
  put_reset_cause();
  proto_end();
}

static void put_header(void)
{
  uint8_t i;
  uint32_t n = sample_engine.n;
  uint32_t drops = adc_drops() + sample_stats.refused;
  put_seq('H');
  put_identity();
  proto_puts_P(PSTR(",fcpu="));
  proto_u32(F_CPU);
  proto_puts_P(PSTR(",baud="));
  proto_u32(BAUD);
  proto_puts_P(PSTR(",fs="));
  proto_u32(adc_rate());
  proto_puts_P(PSTR(",levels="));
  proto_u32(ALLAN_LEVELS);
  proto_puts_P(PSTR(",n="));
  proto_u32(n);
  proto_puts_P(PSTR(",drops="));
  proto_u32(drops);
  proto_puts_P(PSTR(",clips="));
  for (i = 0; i < ADC_COLUMNS; i++) {
    if (i)
      proto_putc(':');
    proto_u32(sample_stats.clips[i]);
  }
  proto_puts_P(PSTR(",temp="));
  if (sample_stats.temp_n) {
    /* mean to one decimal, without overflowing 32 bits */
    uint32_t q = sample_stats.temp_sum / sample_stats.temp_n;
    uint32_t r = sample_stats.temp_sum % sample_stats.temp_n;
    uint32_t tenth = (r * 10u + sample_stats.temp_n / 2u) / sample_stats.temp_n;
    if (tenth == 10) {
      q++;
      tenth = 0;
    }
    proto_u32(q);
    proto_putc('.');
    proto_u32(tenth);
    proto_putc(':');
    proto_u32(sample_stats.temp_min);
    proto_putc(':');
    proto_u32(sample_stats.temp_max);
  } else {
    proto_putc('-');
  }
  sample_temp_restart();
  proto_puts_P(PSTR(",run="));
  proto_putc(adc_running() ? '1' : '0');
  proto_putc(',');
  put_reset_cause();
  proto_end();
}

static void put_row(uint8_t ch, uint8_t level)
{
  uint16_t hi;
  uint32_t lo, pairs;
  uint8_t flags;
  /* Snapshot before any character goes out (see the top of this file). */
  allan_acc(&sample_engine, ch, level, &hi, &lo);
  pairs = allan_pairs(&sample_engine, level);
  flags = allan_flags(&sample_engine, ch, level);
  put_seq('L');
  put_channel(ch);
  proto_putc(',');
  proto_u32(level);
  proto_putc(',');
  proto_u32(pairs);
  proto_putc(',');
  proto_hex(hi, 4);
  proto_hex(lo, 8);
  proto_putc(',');
  proto_hex(flags, 2);
  proto_end();
}

/* One right-aligned column of the summary table (text in RAM). */
static void put_cell(const char *s, uint8_t len)
{
  while (len++ < 9)
    proto_putc(' ');
  proto_puts(s);
}

static void put_summary(void)
{
  char buf[FMT_SIG3_MAX + 1];
  uint8_t level, ch, len;

  put_seq('S');
  proto_puts_P(PSTR("    tau_s"));
  for (ch = 0; ch < ALLAN_CHANNELS; ch++) {
    proto_puts_P(PSTR("       "));
    put_channel(ch);
  }
  proto_end();

  for (level = 0; level < ALLAN_LEVELS; level++) {
    uint32_t pairs = allan_pairs(&sample_engine, level);
    if (!pairs)
      break;
    put_seq('S');
    len = fmt_tau(buf, level, adc_rate());
    put_cell(buf, len);
    for (ch = 0; ch < ALLAN_CHANNELS; ch++) {
      uint16_t hi;
      uint32_t lo;
      uint8_t flags = allan_flags(&sample_engine, ch, level);
      allan_acc(&sample_engine, ch, level, &hi, &lo);
      pairs = allan_pairs(&sample_engine, level);
      len = fmt_adev(buf, hi, lo, pairs, level);
      if (flags) {
        buf[len++] = '!';
        buf[len] = 0;
      }
      put_cell(buf, len);
    }
    proto_end();
  }
}

void report_send(void)
{
  uint8_t ch, level;
  sample_pump(); /* everything sampled so far is in */
  put_header();
  for (ch = 0; ch < ALLAN_CHANNELS; ch++)
    for (level = 0; level < ALLAN_LEVELS; level++)
      put_row(ch, level);
  put_summary();
  put_seq('E');
  proto_u32((uint32_t)ALLAN_CHANNELS * ALLAN_LEVELS);
  proto_end();
  report_seq++;
}

void report_ok(const char *detail_P)
{
  proto_begin();
  proto_puts_P(PSTR("ok"));
  if (detail_P) {
    proto_putc(' ');
    proto_puts_P(detail_P);
  }
  proto_end();
}

void report_ok_n(const char *detail_P, uint32_t n)
{
  proto_begin();
  proto_puts_P(PSTR("ok "));
  proto_puts_P(detail_P);
  proto_u32(n);
  proto_end();
}

void report_error(uint8_t code, const char *reason_P)
{
  proto_begin();
  proto_puts_P(PSTR("error:"));
  proto_u32(code);
  proto_putc(' ');
  proto_puts_P(reason_P);
  proto_end();
}
