/*
 * report.c - the output scheduler (see report.h).  A job is written line by
 * line and each line step by step; `out` remembers where the job stands.
 * Values are read when the step that prints them runs; an L row reads its
 * three values in its first step, so each row is a consistent snapshot.
 */
#include "report.h"

#include <avr/pgmspace.h>

#include "adc.h"
#include "allan.h"
#include "config.h"
#include "fmt.h"
#include "proto.h"
#include "sample.h"
#include "uart.h"

enum { JOB_NONE, JOB_BOOT, JOB_REPLY, JOB_REPORT };
/* Parts of a report, in order. */
enum { PART_HEADER, PART_ROW, PART_SUM_HEAD, PART_SUM_ROW, PART_END };

static const char channel_names[] PROGMEM = "axayazgxgygz";
static const char cause_names[] PROGMEM = "por\0ext\0bor\0wdt\0";

static struct {
  uint8_t job, part, step;
  uint8_t report_next; /* a report waits for the current job to end */
  uint8_t ch, level;
  uint16_t seq;
  uint8_t reset_cause;
  /* The reply being written, or the L row's snapshot. */
  uint8_t code;       /* 0: ok, else error code */
  const char *text_P;
  uint8_t has_n;
  uint8_t flags;
  uint16_t acc_hi;
  uint32_t n;         /* reply number, or the row's pair count */
  uint32_t acc_lo;
} out;

void report_init(uint8_t cause)
{
  out.reset_cause = cause;
}

uint8_t report_busy(void)
{
  return out.job != JOB_NONE;
}

static void start(uint8_t job)
{
  out.job = job;
  out.part = 0;
  out.step = 0;
  out.ch = 0;
  out.level = 0;
}

void report_boot(void)
{
  start(JOB_BOOT);
}

void report_start(void)
{
  if (out.job != JOB_NONE) {
    out.report_next = 1;
    return;
  }
  sample_pump(); /* everything sampled so far is in */
  start(JOB_REPORT);
}

static void reply(uint8_t code, const char *text_P, uint8_t has_n, uint32_t n)
{
  start(JOB_REPLY);
  out.code = code;
  out.text_P = text_P;
  out.has_n = has_n;
  out.n = n;
}

void report_ok(const char *text_P)
{
  reply(0, text_P, 0, 0);
}

void report_ok_n(const char *text_P, uint32_t n)
{
  reply(0, text_P, 1, n);
}

void report_error(uint8_t code, const char *text_P)
{
  reply(code, text_P, 0, 0);
}

/* ---- pieces ---- */

static void put_channel(uint8_t ch)
{
  proto_putc((char)pgm_read_byte(&channel_names[2 * ch]));
  proto_putc((char)pgm_read_byte(&channel_names[2 * ch + 1]));
}

static void begin_seq(char type)
{
  proto_begin();
  proto_putc(type);
  proto_putc(',');
  proto_u32(out.seq);
  proto_putc(',');
}

static void put_key_u32(const char *key_P, uint32_t v)
{
  proto_puts_P(key_P);
  proto_u32(v);
}

static void put_causes(void)
{
  uint8_t bit, any = 0;
  for (bit = 0; bit < 4; bit++) {
    if (out.reset_cause & (1u << bit)) { /* PORF EXTRF BORF WDRF */
      if (any)
        proto_putc('+');
      proto_puts_P(cause_names + 4 * bit);
      any = 1;
    }
  }
  if (!any)
    proto_puts_P(PSTR("none"));
}

/* One right-aligned 9-character column of the summary table. */
static void put_cell(const char *s, uint8_t len)
{
  while (len++ < 9)
    proto_putc(' ');
  proto_puts(s);
}

/* ---- lines: each returns 1 when its last step is done ----
 * Out of line, so that only the running step's locals are on the stack. */

static __attribute__((noinline)) uint8_t step_identity(uint8_t step)
{
  switch (step) {
  case 0: proto_puts_P(PSTR("proto=1,fw=")); break;
  case 1: proto_puts_P(PSTR(FW_VERSION)); break;
  case 2: proto_puts_P(PSTR(",mcu=" FW_MCU_NAME)); break;
  default: return 1;
  }
  return 0;
}

static __attribute__((noinline)) uint8_t step_boot(uint8_t step)
{
  if (step == 0) {
    proto_begin();
    proto_puts_P(PSTR("B,"));
  } else if (step <= 3) {
    step_identity((uint8_t)(step - 1));
  } else if (step == 4) {
    proto_puts_P(PSTR(",reset="));
  } else if (step == 5) {
    put_causes();
  } else {
    proto_end();
    return 1;
  }
  return 0;
}

static __attribute__((noinline)) uint8_t step_header(uint8_t step)
{
  const uint8_t clip0 = 11, temp = clip0 + ADC_COLUMNS;
  if (step == 0) {
    begin_seq('H');
  } else if (step <= 3) {
    step_identity((uint8_t)(step - 1));
  } else if (step == 4) {
    put_key_u32(PSTR(",fcpu="), F_CPU);
  } else if (step == 5) {
    put_key_u32(PSTR(",baud="), BAUD);
  } else if (step == 6) {
    put_key_u32(PSTR(",fs="), adc_rate());
  } else if (step == 7) {
    put_key_u32(PSTR(",levels="), ALLAN_LEVELS);
    put_key_u32(PSTR(",acc48="), ALLAN_ACC48_FROM);
  } else if (step == 8) {
    put_key_u32(PSTR(",n="), sample_engine.n);
  } else if (step == 9) {
    put_key_u32(PSTR(",drops="), adc_drops());
  } else if (step == 10) {
    proto_puts_P(PSTR(",clips="));
  } else if (step < temp) {
    if (step > clip0)
      proto_putc(':');
    proto_u32(sample_stats.clips[step - clip0]);
  } else if (step == temp) {
    proto_puts_P(PSTR(",temp="));
    if (sample_stats.since_report) {
      /* mean to one decimal, without overflowing 32 bits */
      uint32_t q = sample_stats.temp_sum / sample_stats.since_report;
      uint32_t r = sample_stats.temp_sum % sample_stats.since_report;
      uint32_t tenth = (r * 10u + sample_stats.since_report / 2u) / sample_stats.since_report;
      if (tenth == 10) {
        q++;
        tenth = 0;
      }
      proto_u32(q);
      proto_putc('.');
      proto_u32(tenth);
    } else {
      proto_putc('-');
    }
  } else if (step == temp + 1) {
    if (sample_stats.since_report) {
      put_key_u32(PSTR(":"), sample_stats.temp_min);
      put_key_u32(PSTR(":"), sample_stats.temp_max);
    }
    sample_interval_restart(); /* the next report's interval starts here */
  } else if (step == temp + 2) {
    proto_puts_P(adc_running() ? PSTR(",run=1,reset=") : PSTR(",run=0,reset="));
  } else if (step == temp + 3) {
    put_causes();
  } else {
    proto_end();
    return 1;
  }
  return 0;
}

static __attribute__((noinline)) uint8_t step_row(uint8_t step)
{
  switch (step) {
  case 0:
    /* Snapshot first: the engine moves on while the row drains. */
    allan_acc(&sample_engine, out.ch, out.level, &out.acc_hi, &out.acc_lo);
    out.n = allan_pairs(&sample_engine, out.level);
    out.flags = allan_flags(&sample_engine, out.ch, out.level);
    begin_seq('L');
    put_channel(out.ch);
    put_key_u32(PSTR(","), out.level);
    proto_putc(',');
    break;
  case 1:
    proto_u32(out.n);
    proto_putc(',');
    break;
  case 2:
    proto_hex(out.acc_hi, 4);
    proto_hex(out.acc_lo, 8);
    proto_putc(',');
    proto_hex(out.flags, 2);
    break;
  default:
    proto_end();
    return 1;
  }
  return 0;
}

static __attribute__((noinline)) uint8_t step_sum_head(uint8_t step)
{
  if (step == 0) {
    begin_seq('S');
    proto_puts_P(PSTR("    tau_s"));
  } else if (step <= ALLAN_CHANNELS) {
    proto_puts_P(PSTR("       "));
    put_channel((uint8_t)(step - 1));
  } else {
    proto_end();
    return 1;
  }
  return 0;
}

static __attribute__((noinline)) uint8_t step_sum_row(uint8_t step)
{
  char buf[FMT_SIG3_MAX + 1];
  uint8_t len;
  uint32_t mant;
  int8_t exp;
  if (step == 0) {
    begin_seq('S');
    exp = fmt_tau(&mant, out.level, adc_rate());
    len = fmt_sig3(buf, mant, exp);
    put_cell(buf, len);
  } else if (step <= ALLAN_CHANNELS) {
    uint8_t ch = (uint8_t)(step - 1);
    uint16_t hi;
    uint32_t lo;
    allan_acc(&sample_engine, ch, out.level, &hi, &lo);
    exp = fmt_adev(&mant, hi, lo, allan_pairs(&sample_engine, out.level), out.level);
    len = fmt_sig3(buf, mant, exp);
    if (allan_flags(&sample_engine, ch, out.level)) {
      buf[len++] = '!';
      buf[len] = 0;
    }
    put_cell(buf, len);
  } else {
    proto_end();
    return 1;
  }
  return 0;
}

static __attribute__((noinline)) uint8_t step_reply(uint8_t step)
{
  switch (step) {
  case 0:
    proto_begin();
    if (out.code) {
      proto_puts_P(PSTR("error:"));
      proto_u32(out.code);
      proto_putc(' ');
    } else {
      proto_puts_P(PSTR("ok"));
      if (out.text_P)
        proto_putc(' ');
    }
    break;
  case 1:
    if (out.text_P)
      proto_puts_P(out.text_P);
    if (out.has_n)
      proto_u32(out.n);
    break;
  default:
    proto_end();
    return 1;
  }
  return 0;
}

/* Advance the report by one step; returns 1 when the report is complete. */
static __attribute__((noinline)) uint8_t step_report(void)
{
  uint8_t done;
  switch (out.part) {
  case PART_HEADER:
    done = step_header(out.step);
    break;
  case PART_ROW:
    done = step_row(out.step);
    break;
  case PART_SUM_HEAD:
    done = step_sum_head(out.step);
    break;
  case PART_SUM_ROW:
    done = step_sum_row(out.step);
    break;
  default:
    begin_seq('E');
    proto_u32((uint32_t)ALLAN_CHANNELS * ALLAN_LEVELS);
    proto_end();
    out.seq++;
    return 1;
  }
  out.step++;
  if (!done)
    return 0;
  out.step = 0;
  /* Next line. */
  if (out.part == PART_ROW) {
    if (++out.level < ALLAN_LEVELS)
      return 0;
    out.level = 0;
    if (++out.ch < ALLAN_CHANNELS)
      return 0;
  } else if (out.part == PART_SUM_ROW) {
    if (++out.level < ALLAN_LEVELS && allan_pairs(&sample_engine, out.level))
      return 0;
  }
  out.part++;
  if (out.part == PART_SUM_ROW) {
    out.level = 0;
    if (!allan_pairs(&sample_engine, 0))
      out.part++; /* no pairs yet: no summary rows */
  }
  return 0;
}

void report_poll(void)
{
  while (out.job != JOB_NONE && uart_tx_room() >= REPORT_STEP_MAX) {
    uint8_t done;
    if (out.job == JOB_REPORT) {
      done = step_report();
    } else {
      done = out.job == JOB_BOOT ? step_boot(out.step) : step_reply(out.step);
      out.step++;
    }
    if (done) {
      out.job = JOB_NONE;
      if (out.report_next) {
        out.report_next = 0;
        report_start();
      }
    }
  }
}
