/*
 * report.c - the report lines (see report.h).  Values are read when the
 * step that prints them runs; an L row reads its three values in its first
 * step, so each row is a consistent snapshot while the engine moves on.
 * The step functions are out of line, so that only the running step's
 * locals are on the stack, never beside the Allan engine's deepest path.
 */
#include "report.h"

#include "adc.h"
#include "allan.h"
#include "config.h"
#include "fmt.h"
#include "pgm.h"
#include "proto.h"
#include "sample.h"
#include "settings.h"
#include "vocab.h"

/* Parts of a report, in order. */
/* A report's lines in order (docs/protocol.md): H, L..., S title, S head,
 * S rows, T..., V, E. */
enum { PART_HEADER, PART_ROW, PART_SUM_TITLE, PART_SUM_HEAD, PART_SUM_ROW, PART_TERMS, PART_CHECK, PART_END };

static struct {
  uint8_t part, ch, level;
  uint16_t seq;   /* of the report being written; +1 when one starts */
  uint8_t run_id; /* +1 with every new run (report_new_run) */
  uint8_t reset_cause;
  /* The L row's snapshot; in a T line, the least deviation so far:
   * its key (min_key()) in pairs, its level in acc_hi (0xFFFF: none). */
  uint8_t flags;
  uint16_t acc_hi;
  uint32_t acc_lo;
  uint32_t pairs;
} rep = {.seq = 0xFFFF}; /* the first report is seq 0 */

/* B = sigma_min / 0.664: 2^16 / 0.664, for a mantissa below 2^15. */
#define TERMS_B_SCALE 98699ul
/* Levels whose deviation B may come from: at least this many pairs. */
#define TERMS_B_PAIRS 8u

void report_init(uint8_t cause)
{
  rep.reset_cause = cause;
}

void report_new_run(void)
{
  rep.run_id++;
}

void report_begin(void)
{
  rep.part = PART_HEADER;
  rep.ch = 0;
  rep.level = 0;
  rep.seq++; /* a report cut off keeps its number: the next one differs */
  proto_bound_restart();
}

/* ---- pieces ---- */

/* The engine's pairs and accumulators, out of line: called from many
 * steps, inlined each time they would cost flash the T lines need. */
static __attribute__((noinline)) uint32_t pairs_at(uint8_t level)
{
  return allan_pairs(&sample_engine, level);
}

static __attribute__((noinline)) void acc_at(uint8_t ch, uint8_t level, uint16_t *hi, uint32_t *lo)
{
  allan_acc(&sample_engine, ch, level, hi, lo);
}

static void put_channel(uint8_t ch)
{
  proto_putc((char)pgm_read_byte(&vocab_channels[2 * ch]));
  proto_putc((char)pgm_read_byte(&vocab_channels[2 * ch + 1]));
}

/* `<type>,<seq>,`; H and L lines are bound (their bodies go into the
 * report's V check). */
static void begin_seq(char type)
{
  if (type == 'H' || type == 'L')
    proto_begin_bound();
  else
    proto_begin();
  proto_putc(type);
  proto_putc(',');
  proto_u32(rep.seq);
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
    if (rep.reset_cause & (1u << bit)) { /* PORF EXTRF BORF WDRF */
      if (any)
        proto_putc('+');
      proto_puts_P(vocab_word(vocab_causes, bit));
      any = 1;
    }
  }
  if (!any) /* a warm reset nothing recorded (reset.h) */
    proto_puts_P(PSTR("unknown"));
}

/* One right-aligned 9-character column of the summary table. */
static void put_cell(const char *s, uint8_t len)
{
  while (len++ < 9)
    proto_putc(' ');
  proto_puts(s);
}

/* `proto=1,fw=0.2.0,mcu=atmega168`, in three steps. */
static __attribute__((noinline)) void step_identity(uint8_t step)
{
  switch (step) {
  case 0: put_key_u32(PSTR("proto="), PROTO_VERSION); proto_puts_P(PSTR(",fw=")); break;
  case 1: proto_puts_P(PSTR(FW_VERSION)); break;
  default: proto_puts_P(PSTR(",mcu=" FW_MCU_NAME)); break;
  }
}

uint8_t report_boot_step(uint8_t step)
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

/* `<mean>:<min>:<max>` of the temperature over the report's interval, in
 * one step (at most 16 characters: `1023.0:1023:1023`), so that no sample
 * can come between the mean and the extremes; `-` when the interval holds
 * no sample.  The mean to one decimal without overflowing 32 bits.  The
 * next report's interval starts here. */
static __attribute__((noinline)) void put_temp(void)
{
  uint32_t n = sample_stats.since_report;
  if (n) {
    uint32_t q = sample_stats.temp_sum / n;
    uint32_t r = sample_stats.temp_sum % n;
    uint32_t tenth = (r * 10u + n / 2u) / n;
    if (tenth == 10) {
      q++;
      tenth = 0;
    }
    proto_u32(q);
    proto_putc('.');
    proto_u32(tenth);
    put_key_u32(PSTR(":"), sample_stats.temp_min);
    put_key_u32(PSTR(":"), sample_stats.temp_max);
  } else {
    proto_putc('-');
  }
  sample_interval_restart();
}

static __attribute__((noinline)) uint8_t step_header(uint8_t step)
{
  const uint8_t clip0 = 12, temp = clip0 + ADC_COLUMNS;
  if (step == 0) {
    begin_seq('H');
  } else if (step <= 3) {
    step_identity((uint8_t)(step - 1));
  } else if (step == 4) {
    put_key_u32(PSTR(",id="), rep.run_id);
  } else if (step == 5) {
    put_key_u32(PSTR(",fcpu="), F_CPU);
  } else if (step == 6) {
    put_key_u32(PSTR(",baud="), BAUD);
  } else if (step == 7) {
    put_key_u32(PSTR(",fs="), adc_rate());
  } else if (step == 8) {
    put_key_u32(PSTR(",levels="), ALLAN_LEVELS);
    put_key_u32(PSTR(",acc48="), ALLAN_ACC48_FROM);
  } else if (step == 9) {
    put_key_u32(PSTR(",n="), sample_engine.n);
  } else if (step == 10) {
    put_key_u32(PSTR(",drops="), adc_drops());
  } else if (step == 11) {
    proto_puts_P(PSTR(",clips="));
  } else if (step < temp) {
    if (step > clip0)
      proto_putc(':');
    proto_u32(sample_stats.clips[step - clip0]);
    if (step == temp - 1)
      proto_puts_P(PSTR(",temp="));
  } else if (step == temp) {
    put_temp();
  } else if (step == temp + 1) {
    proto_puts_P(adc_running() ? PSTR(",run=1,mode=") : PSTR(",run=0,mode="));
    proto_puts_P(vocab_word(vocab_modes, settings.mode));
  } else if (step == temp + 2) {
    proto_puts_P(PSTR(",range="));
    proto_puts_P(vocab_word(vocab_ranges, settings.range));
    proto_puts_P(PSTR(",cfg="));
  } else if (step == temp + 3) {
    proto_puts_P(vocab_word(vocab_sources, settings_source));
    proto_puts_P(PSTR(",reset="));
  } else if (step == temp + 4) {
    put_causes();
  } else {
    proto_end();
    return 1;
  }
  return 0;
}

/* `L,<seq>,<ch>,<level>,<pairs>,<acc hex 12>,<flags hex 2>` */
static __attribute__((noinline)) uint8_t step_row(uint8_t step)
{
  switch (step) {
  case 0:
    /* Snapshot first: the engine moves on while the row drains. */
    acc_at(rep.ch, rep.level, &rep.acc_hi, &rep.acc_lo);
    rep.pairs = pairs_at(rep.level);
    rep.flags = allan_flags(&sample_engine, rep.ch, rep.level);
    begin_seq('L');
    put_channel(rep.ch);
    put_key_u32(PSTR(","), rep.level);
    proto_putc(',');
    break;
  case 1:
    proto_u32(rep.pairs);
    proto_putc(',');
    break;
  case 2:
    proto_hex(rep.acc_hi, 4);
    proto_hex(rep.acc_lo, 8);
    proto_putc(',');
    proto_hex(rep.flags, 2);
    break;
  default:
    proto_end();
    return 1;
  }
  return 0;
}

static const char title0_P[] PROGMEM = "Allan deviation ";
static const char title1_P[] PROGMEM = "(ADC counts) by ";
static const char title2_P[] PROGMEM = "tau (s); T lines: ";
static const char title3_P[] PROGMEM = "N, B in counts";

/* The summary's first line says what it shows and in which units. */
static __attribute__((noinline)) uint8_t step_sum_title(uint8_t step)
{
  static const char *const parts[] PROGMEM = {title0_P, title1_P, title2_P, title3_P};
  if (step == 0) {
    begin_seq('S');
    return 0;
  }
  if (step <= 4) {
    proto_puts_P((const char *)pgm_read_ptr(&parts[step - 1]));
    return 0;
  }
  proto_end();
  return 1;
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

/* One right-aligned cell of 3 significant digits, '!' when flagged: its
 * text buffer lives here, off the stack of the line's other calls
 * (begin_seq's number formatting is the report's deepest path). */
static __attribute__((noinline)) void put_sig3_cell(uint32_t mant, int8_t exp, uint8_t flagged)
{
  char buf[FMT_SIG3_MAX + 1];
  uint8_t len = fmt_sig3(buf, mant, exp);
  if (flagged) {
    buf[len++] = '!';
    buf[len] = 0;
  }
  put_cell(buf, len);
}

/* The cells of a summary row (begin_seq is not under them: step_sum_row). */
static __attribute__((noinline)) uint8_t sum_row_cells(uint8_t step)
{
  uint32_t mant;
  int8_t exp;
  if (step == 0) {
    exp = fmt_tau(&mant, rep.level, adc_rate());
    put_sig3_cell(mant, exp, 0);
  } else if (step <= ALLAN_CHANNELS) {
    uint8_t ch = (uint8_t)(step - 1);
    uint16_t hi;
    uint32_t lo;
    acc_at(ch, rep.level, &hi, &lo);
    exp = fmt_adev(&mant, hi, lo, pairs_at(rep.level), rep.level);
    put_sig3_cell(mant, exp, allan_flags(&sample_engine, ch, rep.level) != 0);
  } else {
    proto_end();
    return 1;
  }
  return 0;
}

static uint8_t step_sum_row(uint8_t step)
{
  if (step == 0)
    begin_seq('S');
  return sum_row_cells(step);
}

/* `V,<seq>,id=<run>,crc=<XXXX>`: the run and the CRC-16/MODBUS of the
 * bodies of this report's H and L lines (docs/protocol.md). */
static __attribute__((noinline)) uint8_t step_check(uint8_t step)
{
  if (step == 0) {
    begin_seq('V');
    put_key_u32(PSTR("id="), rep.run_id);
  } else if (step == 1) {
    proto_puts_P(PSTR(",crc="));
    proto_hex(proto_bound(), 4);
  } else {
    proto_end();
    return 1;
  }
  return 0;
}

/* The level whose tau = 2^level / fs is nearest 1 s (ties: the lower),
 * among those with pairs. */
static uint8_t terms_n_level(void)
{
  uint16_t fs = adc_rate();
  uint8_t l, best = 0;
  uint32_t m = 1, best_d = 0xFFFFFFFFul;
  for (l = 0; l < ALLAN_LEVELS && pairs_at(l); l++, m <<= 1) {
    uint32_t d = m > fs ? m - fs : fs - m;
    if (d < best_d) {
      best_d = d;
      best = l;
    }
  }
  return best;
}

static __attribute__((noinline)) void put_sig3(uint32_t mant, int8_t exp)
{
  char buf[FMT_SIG3_MAX + 1];
  fmt_sig3(buf, mant, exp);
  proto_puts(buf);
}

/* The deviation of the T line's channel at level l as mant * 2^exp
 * (returned); with `n`, times sqrt(tau): N^2 = acc / (2 pairs m^2) * m / fs
 * = acc / (2 pairs fs 2^l), i.e. fmt_adev with pairs' = pairs fs (times 2
 * for an odd l) and level l / 2.  0 pairs: mant 0. */
static __attribute__((noinline)) int8_t level_dev(uint8_t l, uint8_t n, uint32_t *mant)
{
  uint16_t hi;
  uint32_t lo, pairs = pairs_at(l);
  uint8_t lv = l;
  acc_at(rep.ch, l, &hi, &lo);
  if (n) {
    lv = (uint8_t)(l >> 1);
    while (pairs >= (1ul << 21)) { /* pairs' within 32 bits */
      pairs >>= 2;
      lv++;
    }
    pairs *= adc_rate();
    if (l & 1u)
      pairs <<= 1;
  }
  return fmt_adev(mant, hi, lo, pairs, lv);
}

/* `T,<seq>,<ch>,<level N>,<N>,<level B>,<B>`: the noise terms read off
 * the channel's deviations (docs/protocol.md), in counts: N = sigma(tau)
 * sqrt(tau) in count sqrt(s) at the level nearest 1 s, and B = min sigma
 * / 0.664 in counts over the levels with at least 8 pairs (T lines come
 * only when level 0 has that many).  One level is looked at per step. */
static inline __attribute__((always_inline)) uint8_t step_terms(uint8_t step)
{
  /* The mantissa lives in rep.acc_lo (the L rows' snapshot, free once
   * they are out), not on the stack: this step is inlined into the main
   * loop, whose frame lies under every other one. */
#define mant rep.acc_lo
  uint8_t l;
  int8_t exp;
  if (step == 0) {
    begin_seq('T');
    put_channel(rep.ch);
    proto_putc(',');
    rep.pairs = 0xFFFFFFFFul;
  } else if (step == 1) {
    l = terms_n_level();
    exp = level_dev(l, 1, &mant);
    proto_u32(l);
    proto_putc(',');
    put_sig3(mant, exp);
    proto_putc(',');
  } else if (step < 2 + ALLAN_LEVELS) {
    l = (uint8_t)(step - 2);
    if (pairs_at(l) >= TERMS_B_PAIRS) {
      /* mant is 0 or in [2^14, 2^15): (exp + 128, mant) orders as one number */
      exp = level_dev(l, 0, &mant);
      if (mant)
        mant |= (uint32_t)(uint8_t)(exp + 128) << 16;
      if (mant < rep.pairs) {
        rep.pairs = mant;
        rep.acc_hi = l;
      }
    }
  } else if (step == 2 + ALLAN_LEVELS) {
    proto_u32(rep.acc_hi); /* level 0 has 8 pairs at least: T lines come only then */
    proto_putc(',');
    put_sig3((rep.pairs & 0xFFFFu) * TERMS_B_SCALE, (int8_t)((uint8_t)(rep.pairs >> 16) - 128 - 16));
  } else {
    proto_end();
    return 1;
  }
  return 0;
#undef mant
}

/* After a whole line: the part and row the next line belongs to. */
static void next_line(void)
{
  if (rep.part == PART_ROW) {
    if (++rep.level < ALLAN_LEVELS)
      return;
    rep.level = 0;
    if (++rep.ch < ALLAN_CHANNELS)
      return;
  } else if (rep.part == PART_SUM_ROW) {
    if (++rep.level < ALLAN_LEVELS && pairs_at(rep.level))
      return;
    rep.ch = 0;
    if (pairs_at(0) < TERMS_B_PAIRS)
      rep.part++; /* too few pairs for the terms: no T lines */
  } else if (rep.part == PART_TERMS) {
    if (++rep.ch < ALLAN_CHANNELS)
      return;
  }
  rep.part++;
  if (rep.part == PART_SUM_ROW) {
    rep.level = 0;
    if (!pairs_at(0))
      rep.part += 2; /* no pairs yet: no summary rows, no terms (V follows) */
  }
}

uint8_t report_step(uint8_t step)
{
  uint8_t done;
  /* The engine's waiting pairs for the level about to be read, here on a
   * short stack rather than inside allan_acc under step_row/step_sum_row.
   * A summary row reads a channel a step, and sets taken between two
   * steps may leave the level waiting again: settle before each of them. */
  if ((rep.part == PART_ROW && step == 0) || rep.part == PART_SUM_ROW || rep.part == PART_TERMS)
    allan_settle_level(&sample_engine, rep.level); /* T lines: lagging channels caught up here */
  switch (rep.part) {
  case PART_HEADER: done = step_header(step); break;
  case PART_ROW: done = step_row(step); break;
  case PART_SUM_TITLE: done = step_sum_title(step); break;
  case PART_SUM_HEAD: done = step_sum_head(step); break;
  case PART_SUM_ROW: done = step_sum_row(step); break;
  case PART_TERMS: done = step_terms(step); break;
  case PART_CHECK: done = step_check(step); break;
  default:
    begin_seq('E');
    proto_u32((uint32_t)ALLAN_CHANNELS * ALLAN_LEVELS);
    proto_end();
    return REPORT_DONE;
  }
  if (!done)
    return REPORT_MORE;
  next_line();
  return REPORT_LINE_DONE;
}
