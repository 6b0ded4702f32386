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
#include "board.h"
#include "config.h"
#include "console.h"
#include "fmt.h"
#include "pgm.h"
#include "proto.h"
#include "reply.h"
#include "reset.h"
#include "sample.h"
#include "settings.h"
#include "units.h"
#include "vocab.h"

/* A report's lines in order (docs/protocol.md): the machine's H, L...,
 * T..., V, then the summary a person reads, last on the screen: S title,
 * S head, S rows, S caption and terms rows; E. */
enum {
  PART_HEADER,
  PART_ROW,
  PART_TERMS,
  PART_CHECK,
  PART_SUM_TITLE,
  PART_SUM_HEAD,
  PART_SUM_ROW,
  PART_SUM_CAPTION,
  PART_SUM_TERMS,
  PART_END
};

static struct {
  uint8_t part, ch, level;
  uint16_t seq;   /* of the report being written; +1 when one starts */
  uint8_t run_id; /* +1 with every new run (report_new_run) */
  union {
    struct { /* an L row's snapshot */
      uint8_t flags;
      uint16_t acc_hi;
      uint32_t acc_lo;
      uint32_t pairs;
    };
    struct {            /* after the L rows, for the terms: */
      uint32_t b_key;   /* B's search in a T line: the least deviation so far; value_at's mant */
      uint8_t n_level1; /* N's level + 1, the same for every channel; 0: no terms */
      uint8_t b_level[ALLAN_CHANNELS]; /* B's level of each channel (its search's so far) */
    };
  };
} rep; /* in .bss: report_init() sets what is not 0 */

void report_init(void)
{
  rep.seq = 0xFFFF; /* the first report is seq 0 */
}

void report_new_run(void)
{
  rep.run_id++;
}

/* The units setting as the report began (in its header): a `units` typed
 * while it is sent takes effect with the next one.  A flag of board.h's
 * (no SRAM). */
#define rep_counts() (BOARD_FLAGS & BOARD_FLAG_COUNTS)

void report_begin(void)
{
  if (settings.counts)
    BOARD_FLAGS |= BOARD_FLAG_COUNTS;
  else
    BOARD_FLAGS &= (uint8_t)~BOARD_FLAG_COUNTS;
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
  const char *p = &vocab_channels[2 * ch];
  proto_putc((char)pgm_read_byte(p));
  proto_putc((char)pgm_read_byte(p + 1));
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

/* The boot line's and the header's (one copy in flash); the header's and
 * the V line's `id=` (id_key_P + 1). */
static const char reset_key_P[] PROGMEM = ",reset=";
static const char id_key_P[] PROGMEM = ",id=";
/* One-character keys, each once in flash. */
static const char colon_P[] PROGMEM = ":";
static const char comma_P[] PROGMEM = ",";

/* `<type>,<seq>,<ch>,<level>,` of an L or T line, channel rep.ch. */
static void begin_channel(char type, uint8_t level)
{
  begin_seq(type);
  put_channel(rep.ch);
  put_key_u32(comma_P, level);
  proto_putc(',');
}

static void put_causes(void)
{
  uint8_t bit, any = 0, cause = reset_cause();
  for (bit = 0; bit < 4; bit++) {
    if (cause & (1u << bit)) { /* PORF EXTRF BORF WDRF */
      if (any)
        proto_putc('+');
      proto_puts_P(vocab_word(vocab_causes, bit));
      any = 1;
    }
  }
  if (!any) /* a warm reset nothing recorded (reset.h) */
    proto_puts_P(PSTR("unknown"));
}

/* `proto=1,fw=0.2.0,mcu=atmega168`, in three steps. */
static __attribute__((noinline)) void step_identity(uint8_t step)
{
  switch (step) {
  case 0:
    put_key_u32(PSTR("proto="), PROTO_VERSION);
    proto_puts_P(PSTR(",fw="));
    break;
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
    proto_puts_P(reset_key_P);
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
 * no sample.  The mean to one decimal (fmt_mean: exact over the longest
 * interval).  The next report's interval starts after this step: a flag
 * says so to the loop's pass (loop.c), which restarts it before it takes
 * another set. */
static __attribute__((noinline)) void put_temp(void)
{
  uint32_t n = sample_stats.since_report;
  if (n) {
    uint32_t mean = fmt_mean(n, sample_stats.temp_sum, sample_stats.temp_sum_hi);
    proto_u32((uint16_t)mean);
    proto_putc('.');
    proto_putc((char)('0' + (uint8_t)(mean >> 16)));
    put_key_u32(colon_P, sample_stats.temp_min);
    put_key_u32(colon_P, sample_stats.temp_max);
  } else {
    proto_putc('-');
  }
  BOARD_FLAGS |= BOARD_FLAG_INTERVAL;
}

/* config.h's numbers as text (plain integer literals there). */
#define REP_STR_(x) #x
#define REP_STR(x) REP_STR_(x)

static __attribute__((noinline)) uint8_t step_header(uint8_t step)
{
  const uint8_t clip0 = 12, temp = clip0 + ADC_COLUMNS;
  if (step == 0) {
    begin_seq('H');
  } else if (step <= 3) {
    step_identity((uint8_t)(step - 1));
  } else if (step == 4) {
    put_key_u32(id_key_P, rep.run_id);
  } else if (step == 5) {
    put_key_u32(PSTR(",fcpu="), F_CPU);
  } else if (step == 6) {
    put_key_u32(PSTR(",baud="), BAUD);
  } else if (step == 7) {
    put_key_u32(PSTR(",fs="), adc_rate());
  } else if (step == 8) {
    proto_puts_P(PSTR(",levels=" REP_STR(ALLAN_LEVELS) ",acc48=" REP_STR(ALLAN_ACC48_FROM)));
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
  } else if ((uint8_t)(step - temp - 1) < SETTINGS_IN_HEADER) {
    reply_put_setting((uint8_t)(step - temp - 1), ',', rep_counts() != 0);
  } else if (step == temp + 1 + SETTINGS_IN_HEADER) {
    proto_puts_P(reset_key_P);
  } else if (step == temp + 2 + SETTINGS_IN_HEADER) {
    put_causes();
  } else if ((uint8_t)(step - temp - 3 - SETTINGS_IN_HEADER) < CONSOLE_COUNTS) {
    console_put_count((uint8_t)(step - temp - 3 - SETTINGS_IN_HEADER), ',');
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
    begin_channel('L', rep.level);
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
  default: proto_end(); return 1;
  }
  return 0;
}

/* put_at's styles: a right-aligned 9-character cell, a flagged value
 * (ends in '!'), in counts whatever the units setting. */
#define AT_CELL 1u
#define AT_FLAGGED 2u
#define AT_COUNTS 4u

/* mant * 2^exp with 3 significant digits, as put_at's style says.  Its
 * text buffer lives here, off the stack of the line's other calls
 * (begin_seq's number formatting is the report's deepest path). */
static __attribute__((noinline)) void put_sig3(uint32_t mant, int8_t exp, uint8_t style)
{
  char buf[FMT_SIG3_MAX];
  uint8_t len = fmt_sig3(buf, mant, exp) + (style & AT_FLAGGED ? 1 : 0);
  while ((style & AT_CELL) && len++ < 9)
    proto_putc(' ');
  proto_puts(buf);
  if (style & AT_FLAGGED)
    proto_putc('!');
}

/* What put_at prints at a level: a quantity of units.h for channel
 * rep.ch (its deviation, N = sigma sqrt(tau) or B = sigma / 0.664), tau
 * in seconds, or the uncertainty from the level's pairs in percent,
 * 100 / sqrt(2 pairs) (white noise, non-overlapping EDF), as fmt_adev
 * computes sqrt(10000 / (2 pairs)). */
#define AT_PCT 3 /* UNITS_QUANTITIES */
#define AT_TAU 4
_Static_assert(AT_PCT == UNITS_QUANTITIES, "AT_PCT follows the quantities of units.h");

/* `what` at level l as mant * 2^exp: exp returned, mant left in rep.b_key
 * (free but in B's search, which keeps its least aside), in counts with
 * AT_COUNTS or in the units setting's.  N^2 = acc / (2 pairs m^2) * m / fs
 * = acc / (2 pairs fs 2^l), i.e. fmt_adev with pairs' = pairs fs (times 2
 * for an odd l) and level l / 2.  In counts the deviation comes out
 * unscaled (units.h): mant 0 or in [2^14, 2^15). */
static __attribute__((noinline)) int8_t value_at(uint8_t what, uint8_t l, uint8_t style)
{
  uint32_t mant, lo = 10000ul, pairs = pairs_at(l);
  uint16_t hi = 0;
  uint8_t lv = 0, kind = UNITS_COUNTS;
  int8_t exp;
  if (what == AT_TAU) {
    exp = fmt_tau(&mant, l, adc_rate());
  } else {
    if (what != AT_PCT) {
      acc_at(rep.ch, l, &hi, &lo);
      lv = l;
      if (what == UNITS_N) {
        lv = (uint8_t)(l >> 1);
        while (pairs >= (1ul << 21)) { /* pairs' within 32 bits */
          pairs >>= 2;
          lv++;
        }
        pairs *= adc_rate();
        if (l & 1u)
          pairs <<= 1;
      }
      if (!(style & AT_COUNTS) && !rep_counts())
        kind = rep.ch < 3 ? (uint8_t)(UNITS_ACC + settings.range) : UNITS_GYRO;
    }
    exp = fmt_adev(&mant, hi, lo, pairs, lv);
    if (what != AT_PCT)
      exp = units_scale(&mant, exp, what, kind);
  }
  rep.b_key = mant;
  return exp;
}

/* value_at's reads and arithmetic, then the printing: one after the
 * other, not one under the other (the report's deepest path). */
static __attribute__((noinline)) void put_at(uint8_t what, uint8_t l, uint8_t style)
{
  int8_t exp = value_at(what, l, style);
  put_sig3(rep.b_key, exp, style);
}

/* `V,<seq>,id=<run>,crc=<XXXX>`: the run and the CRC-16/MODBUS of the
 * bodies of this report's H and L lines (docs/protocol.md). */
static __attribute__((noinline)) uint8_t step_check(uint8_t step)
{
  if (step == 0) {
    begin_seq('V');
    put_key_u32(id_key_P + 1, rep.run_id);
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
 * among those with pairs (levels 0 up to some level have them). */
static uint8_t terms_n_level(void)
{
  uint16_t fs = adc_rate(), p = 1;
  uint8_t l = 0;
  while (2u * p <= fs) { /* p = 2^l <= fs < 2^(l+1) */
    p *= 2u;
    l++;
  }
  if ((uint16_t)(fs - p) > (uint16_t)(2u * p - fs))
    l++;
  while (l && !pairs_at(l))
    l--;
  return l;
}

#define N_LEVEL ((uint8_t)(rep.n_level1 - 1u))

/* `T,<seq>,<ch>,<level N>,<N>,<level B>,<B>`: the noise terms read off
 * the channel's deviations (docs/protocol.md), in counts: N = sigma(tau)
 * sqrt(tau) in count sqrt(s) at the level nearest 1 s, and B = min sigma
 * / 0.664 in counts over the levels with at least 8 pairs (T lines come
 * only when level 0 has that many).  One level is looked at per step. */
static inline __attribute__((always_inline)) uint8_t step_terms(uint8_t step)
{
  uint8_t l;
  if (step == 0) {
    begin_channel('T', N_LEVEL);
  } else if (step == 1) {
    put_at(UNITS_N, N_LEVEL, AT_COUNTS);
    proto_putc(',');
    rep.b_key = 0xFFFFFFFFul; /* after put_at, which works in it */
  } else if (step < 2 + ALLAN_LEVELS) {
    l = (uint8_t)(step - 2);
    if (pairs_at(l) >= TERMS_B_PAIRS) {
      /* the deviation in counts, mant 0 or in [2^14, 2^15): (exp + 128) << 16
       * | mant orders as it does */
      uint32_t least = rep.b_key, key;
      int8_t exp = value_at(UNITS_ADEV, l, AT_COUNTS);
      key = rep.b_key;
      if (key)
        key |= (uint32_t)(uint8_t)(exp + 128) << 16;
      rep.b_key = least;
      if (key < least) {
        rep.b_key = key;
        rep.b_level[rep.ch] = l;
      }
    }
  } else if (step == 2 + ALLAN_LEVELS) {
    l = rep.b_level[rep.ch]; /* level 0 has 8 pairs at least */
    proto_u32(l);
    proto_putc(',');
    put_at(UNITS_B, l, AT_COUNTS);
  } else {
    proto_end();
    return 1;
  }
  return 0;
}

/* The summary's text lines: flash text with control bytes, a step's worth
 * (at most UART_STEP_MAX characters) between two TEXT_STEP: TEXT_RANGE
 * the range word, AT_TAU and AT_PCT N's tau and uncertainty (put_at),
 * TEXT_UNITS where the words of phys and counts part.
 * The first line says what it shows and in which units; the caption of
 * the noise terms says N's tau and uncertainty (the same for every
 * channel) and the units of N and B. */
#define TEXT_STEP "\001"
#define TEXT_RANGE "\002"
#define TEXT_PCT "\003"   /* AT_PCT */
#define TEXT_TAU "\004"   /* AT_TAU */
#define TEXT_UNITS "\005" /* the text goes on in the units' own words */

static const char title_P[] PROGMEM = "Allan deviation " TEXT_STEP "by tau (s): " TEXT_STEP TEXT_UNITS;
static const char title_phys_P[] PROGMEM = "accel mg at +-" TEXT_RANGE TEXT_STEP " g, gyro deg/s";
static const char title_counts_P[] PROGMEM = "ADC counts";
static const char caption_P[] PROGMEM =
    "N at " TEXT_TAU " s +-" TEXT_STEP TEXT_PCT "%: " TEXT_STEP TEXT_UNITS;
static const char caption_phys_P[] PROGMEM = "m/s/rt(h), deg/rt(h)" TEXT_STEP "; B: mg, deg/h";
static const char caption_counts_P[] PROGMEM = "count rt(s)" TEXT_STEP "; B: counts";

static __attribute__((noinline)) uint8_t step_sum_text(uint8_t step)
{
  const char *p;
  char c;
  p = rep.part == PART_SUM_TITLE ? title_P : caption_P;
  for (;;) {
    c = (char)pgm_read_byte(p++);
    if (c == TEXT_UNITS[0]) {
      if (rep.part == PART_SUM_TITLE)
        p = rep_counts() ? title_counts_P : title_phys_P;
      else
        p = rep_counts() ? caption_counts_P : caption_phys_P;
    } else if (!c) {
      if (step > 1) {
        proto_end();
        return 1;
      }
      return 0;
    } else if (c == TEXT_STEP[0]) {
      if (--step == 0)
        return 0;
    } else if (step > 1) {
      /* an earlier step's text */
    } else if (c == TEXT_RANGE[0])
      proto_puts_P(vocab_word(vocab_ranges, settings.range));
    else if (c < ' ')
      put_at((uint8_t)c, N_LEVEL, 0);
    else
      proto_putc(c);
  }
}

/* The labels of the summary's column heading and of the rows of the noise
 * terms under the channels' columns (rep.level: the row): N, B, then B's
 * uncertainty in percent and its tau, by row (row + 1) % 4. */
static const char row_labels_P[] PROGMEM = "    tau_s\0        N\0        B\0      +-%";

/* The cells of a row of the summary's table: the column heading, a
 * level's deviations (after its tau) or a row of the terms (after its
 * label), from step 0 after the line's begin_seq (report_step). */
static __attribute__((noinline)) uint8_t sum_row_cells(uint8_t step)
{
  uint8_t row = rep.level, ch = (uint8_t)(step - 1), part = rep.part;
  if (step == 0) {
    if (part == PART_SUM_ROW)
      put_at(AT_TAU, row, AT_CELL);
    else
      proto_puts_P(vocab_word(row_labels_P, part == PART_SUM_HEAD ? 0 : (uint8_t)(row + 1) & 3u));
  } else if (step <= ALLAN_CHANNELS) {
    rep.ch = ch;
    if (part == PART_SUM_HEAD) {
      proto_puts_P(PSTR("       "));
      put_channel(ch);
    } else if (part == PART_SUM_TERMS) {
      put_at((uint8_t)(row + 1), row ? rep.b_level[ch] : N_LEVEL, AT_CELL); /* N, B, AT_PCT, AT_TAU */
    } else {
      put_at(UNITS_ADEV, row, allan_flags(&sample_engine, ch, row) ? AT_CELL | AT_FLAGGED : AT_CELL);
    }
  } else {
    proto_end();
    return 1;
  }
  return 0;
}

/* After a whole line: the part and row the next line belongs to. */
static void next_line(void)
{
  switch (rep.part) {
  case PART_ROW:
    if (++rep.level < ALLAN_LEVELS)
      return;
    rep.level = 0;
    if (++rep.ch < ALLAN_CHANNELS)
      return;
    rep.ch = 0;
    rep.n_level1 = 0;
    if (pairs_at(0) >= TERMS_B_PAIRS)
      rep.n_level1 = (uint8_t)(terms_n_level() + 1u);
    else
      rep.part++; /* too few pairs for the terms: no T lines */
    break;
  case PART_TERMS:
    if (++rep.ch < ALLAN_CHANNELS)
      return;
    break;
  case PART_SUM_ROW:
    if (++rep.level < ALLAN_LEVELS && pairs_at(rep.level))
      return;
    rep.level = 0;
    if (!rep.n_level1)
      rep.part += 2; /* no T lines: no terms */
    break;
  case PART_SUM_TERMS:
    if (++rep.level < 4)
      return;
    break;
  }
  rep.part++;
  if (rep.part == PART_SUM_ROW && !pairs_at(0))
    rep.part = PART_END; /* no pairs yet: no summary rows, no terms */
}

uint8_t report_step(uint8_t step)
{
  uint8_t done;
  /* The engine is read settled: the sampling loop takes its waiting work
   * (sample_settle) before the output's turn. */
  if (step == 0 && rep.part >= PART_SUM_TITLE && rep.part < PART_END) {
    begin_seq('S'); /* a summary line's first step: the text follows */
    return REPORT_MORE;
  }
  switch (rep.part) {
  case PART_HEADER: done = step_header(step); break;
  case PART_ROW: done = step_row(step); break;
  case PART_TERMS: done = step_terms(step); break;
  case PART_CHECK: done = step_check(step); break;
  case PART_SUM_TITLE:
  case PART_SUM_CAPTION: done = step_sum_text(step); break;
  case PART_SUM_HEAD:
  case PART_SUM_ROW:
  case PART_SUM_TERMS: done = sum_row_cells((uint8_t)(step - 1)); break;
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
