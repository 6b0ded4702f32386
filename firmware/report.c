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
#include "command.h"
#include "config.h"
#include "crc.h"
#include "fmt.h"
#include "link.h"
#include "proto.h"
#include "sample.h"
#include "settings.h"
#include "uart.h"

enum { JOB_NONE, JOB_BOOT, JOB_REPLY, JOB_REPORT, JOB_STATUS, JOB_HELP };
/* Parts of a report, in order. */
enum { PART_HEADER, PART_ROW, PART_SUM_HEAD, PART_SUM_ROW, PART_END };

static const char channel_names[] PROGMEM = "axayazgxgygz";
static const char cause_names[] PROGMEM = "por\0ext\0bor\0wdt\0";

static struct {
  uint8_t job, part, step;
  uint8_t report_next; /* a report waits for the current job to end */
  uint8_t paused;      /* a report waits for the reply written between its lines */
  uint8_t hold_rows;   /* a new run's rows wait for the reply that started it */
  uint8_t row_step;    /* raw row in progress: next step, 0 when none */
  uint8_t row_done;    /* the oldest set's row or frame is written */
  uint32_t rows;       /* rows or frames written since report_restart_rows() */
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
  return out.job != JOB_NONE || out.row_step;
}

uint8_t report_holds_sample(void)
{
  return settings.mode != MODE_ALLAN && !out.row_done;
}

void report_sample_taken(void)
{
  out.row_done = 0;
}

void report_restart_rows(void)
{
  out.row_step = 0;
  out.row_done = 0;
  out.rows = 0;
  out.hold_rows = 1; /* released when the next reply is written */
}

/* A new job.  A reply may come between two lines of a report: the report
 * pauses (its place is kept in part/ch/level) and resumes after it. */
static void start(uint8_t job)
{
  if (out.job == JOB_REPORT && job != JOB_REPORT)
    out.paused = 1;
  out.job = job;
  out.step = 0;
  if (job == JOB_REPORT) {
    out.part = 0;
    out.ch = 0;
    out.level = 0;
  }
}

void report_abort(void)
{
  if (out.job == JOB_REPORT)
    out.job = JOB_NONE;
  out.paused = 0;
  out.report_next = 0;
}

uint8_t report_can_interject(void)
{
  /* Between two lines of a report (or with no job), and not inside a raw
   * row or a count line of our own. */
  return (out.job == JOB_NONE || (out.job == JOB_REPORT && out.step == 0)) &&
         out.row_step != 1 && out.row_step != 3;
}

void report_boot(void)
{
  start(JOB_BOOT);
}

void report_start(void)
{
  if (out.job != JOB_NONE || out.paused) {
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

void report_status(void)
{
  start(JOB_STATUS);
}

void report_help(void)
{
  start(JOB_HELP);
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
    proto_puts_P(adc_running() ? PSTR(",run=1,mode=") : PSTR(",run=0,mode="));
    proto_puts_P(command_mode_name(settings.mode));
  } else if (step == temp + 3) {
    proto_puts_P(PSTR(",range="));
    proto_puts_P(command_range_name(settings.range));
    proto_puts_P(PSTR(",cfg="));
  } else if (step == temp + 4) {
    proto_puts_P(settings_source_name(settings_source));
    proto_puts_P(PSTR(",reset="));
  } else if (step == temp + 5) {
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

/* `ok status run= fs= mode= range= interval= link= cfg=` */
static __attribute__((noinline)) uint8_t step_status(uint8_t step)
{
  switch (step) {
  case 0:
    proto_begin();
    proto_puts_P(adc_running() ? PSTR("ok status run=1") : PSTR("ok status run=0"));
    break;
  case 1:
    put_key_u32(PSTR(" fs="), adc_rate());
    proto_puts_P(PSTR(" mode="));
    break;
  case 2:
    proto_puts_P(command_mode_name(settings.mode));
    proto_puts_P(PSTR(" range="));
    proto_puts_P(command_range_name(settings.range));
    break;
  case 3:
    put_key_u32(PSTR(" interval="), settings.interval_s);
    break;
  case 4:
    put_key_u32(PSTR(" link="), link_percent(settings.mode, adc_rate(), BAUD));
    proto_puts_P(PSTR(" cfg="));
    break;
  case 5:
    proto_puts_P(settings_source_name(settings_source));
    break;
  default:
    proto_end();
    return 1;
  }
  return 0;
}

static __attribute__((noinline)) uint8_t step_help(uint8_t step)
{
  switch (step) {
  case 0:
    proto_begin();
    proto_puts_P(PSTR("ok help report reset"));
    break;
  case 1: proto_puts_P(PSTR(" stop start rate")); break;
  case 2: proto_puts_P(PSTR(" interval mode range")); break;
  case 3: proto_puts_P(PSTR(" save load defaults")); break;
  case 4: proto_puts_P(PSTR(" status help")); break;
  default:
    proto_end();
    return 1;
  }
  return 0;
}

/* `$C,<rows>,<drops>`: rows or frames written, and sets the device lost. */
static void put_count_line(uint8_t step)
{
  if (step == 0) {
    proto_begin();
    put_key_u32(PSTR("C,"), out.rows);
  } else {
    put_key_u32(PSTR(","), adc_drops());
    proto_end();
  }
}

/* The raw row or count line in progress (out.row_step):
 *   1: the second half of a raw row; 2, 3: the two halves of a count line. */
static __attribute__((noinline)) void step_raw_row(void)
{
  uint16_t code[ADC_COLUMNS];
  char buf[10];
  uint8_t i, n, first, last;
  if (out.row_step >= 2) {
    put_count_line((uint8_t)(out.row_step - 2));
    out.row_step = out.row_step == 2 ? 3 : 0;
    return;
  }
  /* A raw thesis row of the oldest set, in two steps of at most 20
   * characters: codes 0..3, then 4..6 and the line end. */
  adc_peek(code);
  first = out.row_step ? 4 : 0;
  last = out.row_step ? ADC_COLUMNS : 4;
  for (i = first; i < last; i++) {
    uint8_t j;
    n = fmt_u32(buf, code[i]);
    for (j = 0; j < n; j++)
      uart_write((uint8_t)buf[j]);
    if (i + 1 < ADC_COLUMNS)
      uart_write('\t');
  }
  if (!out.row_step) {
    out.row_step = 1;
    return;
  }
  uart_write('\r');
  uart_write('\n');
  out.row_done = 1;
  out.rows++;
  out.row_step = out.rows % LINK_COUNT_EVERY == 0 ? 2 : 0; /* count line due */
}

/* One 13-byte binary frame of the oldest set (docs/protocol.md).  Frames
 * may cut into a text line: text never holds 0xA5. */
static __attribute__((noinline)) void put_frame(void)
{
  uint8_t b[PROTO_FRAME_BYTES], i;
  adc_peek_packed(b + 2); /* the payload lands where the frame wants it */
  proto_frame(b, (uint8_t)out.rows, b + 2);
  for (i = 0; i < PROTO_FRAME_BYTES; i++)
    uart_write(b[i]);
  out.row_done = 1;
  out.rows++;
  if (out.rows % LINK_COUNT_EVERY == 0)
    out.row_step = 2; /* count line due, at the next line boundary */
}

/* Advance the report by one step; returns 1 when the report is complete. */
static __attribute__((noinline)) uint8_t step_report(void)
{
  uint8_t done;
  if (out.step == 0 && (out.part == PART_ROW || out.part == PART_SUM_ROW))
    allan_settle_level(&sample_engine, out.level); /* the engine's waiting pairs, on a short stack */
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

/* 1 when the current job stands between two lines, where a raw row may go. */
static uint8_t at_line_boundary(void)
{
  return out.job == JOB_NONE || out.step == 0;
}

void report_poll(void)
{
  while (uart_tx_room() >= REPORT_STEP_MAX) {
    uint8_t done;
    /* Our own lines first: a raw row or count line once begun is finished,
     * a count line begins between two lines of the current job. */
    if (out.row_step == 1 || out.row_step == 3 || (out.row_step == 2 && at_line_boundary())) {
      step_raw_row();
      continue;
    }
    /* Then the samples: frames anywhere, raw rows between lines; those of
     * a new run only after the reply that started it. */
    if (settings.mode != MODE_ALLAN && !out.row_done && !out.hold_rows && adc_pending()) {
      if (settings.mode == MODE_BINARY) {
        if (out.row_step != 3) { /* not inside a count line */
          put_frame();
          continue;
        }
      } else if (!out.row_step && at_line_boundary()) {
        step_raw_row();
        continue;
      }
    }
    if (out.job == JOB_NONE)
      break;
    if (out.job == JOB_REPORT) {
      done = step_report();
    } else {
      switch (out.job) {
      case JOB_BOOT: done = step_boot(out.step); break;
      case JOB_STATUS: done = step_status(out.step); break;
      case JOB_HELP: done = step_help(out.step); break;
      default: done = step_reply(out.step); break;
      }
      out.step++;
    }
    if (done) {
      if (out.job != JOB_REPORT)
        out.hold_rows = 0;
      out.job = JOB_NONE;
      if (out.paused) {
        out.paused = 0;
        out.job = JOB_REPORT; /* resume at the line it had reached, */
        out.step = 0;         /* from its start */
      } else if (out.report_next) {
        out.report_next = 0;
        report_start();
      }
    }
  }
}
