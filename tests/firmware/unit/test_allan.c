/*
 * Unity tests of firmware/allan.c against an independent reference written
 * here: cluster sums taken straight from the sample array (no cascade),
 * squared differences summed exactly in 128-bit integers, and the Allan
 * variance in float64 from cluster means with compensated summation, the
 * way allantools defines the non-overlapping adev.
 *
 * Built twice by CMake: with the ATmega168's 15 levels and with 20 levels
 * (the ATmega328P build), where the 24-bit range bound comes into play.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "allan.h"
#include "unity.h"

#define NCH ALLAN_CHANNELS
#define NLEV ALLAN_LEVELS
/* Largest value a level's accumulator holds (40 or 48 bits). */
#define ACC_MAX(level) ((((unsigned __int128)1) << ALLAN_ACC_BITS(level)) - 1)

static allan_t eng;
static uint16_t *buf; /* n rows of NCH codes */
static uint32_t buf_cap;

/* ---- deterministic random numbers (xorshift64*, seeded) ---- */
static uint64_t rng_state;
static void rng_seed(uint64_t s)
{
  rng_state = s * 0x9E3779B97F4A7C15ull + 1;
}
static uint64_t rng_next(void)
{
  rng_state ^= rng_state >> 12;
  rng_state ^= rng_state << 25;
  rng_state ^= rng_state >> 27;
  return rng_state * 2685821657736338717ull;
}
static uint32_t rng_below(uint32_t n)
{
  return (uint32_t)(rng_next() % n);
}
static double rng_gauss(void)
{
  double u1 = ((rng_next() >> 11) + 1.0) / 9007199254740993.0;
  double u2 = (rng_next() >> 11) / 9007199254740992.0;
  return sqrt(-2.0 * log(u1)) * cos(2.0 * M_PI * u2);
}
static uint16_t clamp_code(double v)
{
  long r = lround(v);
  if (r < 0)
    return 0;
  if (r > (long)ALLAN_CODE_MAX)
    return ALLAN_CODE_MAX;
  return (uint16_t)r;
}

static uint16_t *rows(uint32_t n)
{
  if (n > buf_cap) {
    free(buf);
    buf = malloc((size_t)n * NCH * sizeof *buf);
    TEST_ASSERT_NOT_NULL(buf);
    buf_cap = n;
  }
  return buf;
}

static void push_all(const uint16_t *x, uint32_t n)
{
  for (uint32_t i = 0; i < n; i++)
    TEST_ASSERT_EQUAL_UINT8(ALLAN_OK, allan_push(&eng, &x[(size_t)i * NCH]));
}

/* ---- the independent reference ---- */
typedef struct {
  unsigned __int128 sumsq; /* exact sum of squared cluster-sum differences */
  double avar;             /* float64 Allan variance from cluster means */
  uint32_t pairs;
  uint8_t flags; /* what the engine must report */
} ref_t;

static ref_t reference(const uint16_t *x, uint32_t n, int ch, int level)
{
  ref_t r = {0, 0.0, 0, 0};
  uint32_t m = 1u << level, clusters = n / m;
  uint16_t lo = ALLAN_CODE_MAX, hi = 0;
  double s = 0.0, comp = 0.0; /* Neumaier summation */
  int64_t prev = 0;

  for (uint32_t i = 0; i < n; i++) {
    uint16_t v = x[(size_t)i * NCH + ch];
    if (v < lo)
      lo = v;
    if (v > hi)
      hi = v;
  }
  uint16_t run_lo = ALLAN_CODE_MAX, run_hi = 0; /* range up to the current cluster */
  int range_hit = 0;
  for (uint32_t j = 0; j < clusters; j++) {
    int64_t sum = 0;
    for (uint32_t i = j * m; i < (j + 1) * m; i++) {
      uint16_t v = x[(size_t)i * NCH + ch];
      sum += v;
      if (v < run_lo)
        run_lo = v;
      if (v > run_hi)
        run_hi = v;
    }
    /* A pair taken once the range bound is broken cannot be vouched for:
     * the engine saturates that level for good. */
    if (j > 0 && level >= 15 && (uint64_t)(run_hi - run_lo) * m >= (1u << 23))
      range_hit = 1;
    if (j > 0) {
      int64_t d = sum - prev;
      double dm = (double)sum / m - (double)prev / m, t = dm * dm, u = s + t;
      r.sumsq += (unsigned __int128)(d * d);
      comp += fabs(s) >= t ? (s - u) + t : (t - u) + s;
      s = u;
    }
    prev = sum;
  }
  r.pairs = clusters >= 2 ? clusters - 1 : 0;
  r.avar = r.pairs ? (s + comp) / (2.0 * r.pairs) : 0.0;
  if (n && level >= 15 && (uint64_t)(hi - lo) * m >= (1u << 23))
    r.flags |= ALLAN_FLAG_RANGE;
  if (range_hit || r.sumsq >= ACC_MAX(level))
    r.flags |= ALLAN_FLAG_SAT;
  return r;
}

static unsigned __int128 engine_acc(int ch, int level)
{
  uint16_t hi;
  uint32_t lo;
  allan_acc(&eng, (uint8_t)ch, (uint8_t)level, &hi, &lo);
  return ((unsigned __int128)hi << 32) | lo;
}

static double rel_diff(double a, double b)
{
  if (a == b)
    return 0.0;
  return fabs(a - b) / fmax(fabs(a), fabs(b));
}

/* Compare every channel and level of the engine with the reference.
 * Returns how many channel-levels were checked exactly (no flags). */
static int check_all(const uint16_t *x, uint32_t n, const char *what)
{
  char msg[160];
  int exact = 0;
  TEST_ASSERT_EQUAL_UINT32(n, eng.n);
  for (int ch = 0; ch < NCH; ch++) {
    for (int k = 0; k < NLEV; k++) {
      ref_t r = reference(x, n, ch, k);
      uint8_t flags = allan_flags(&eng, (uint8_t)ch, (uint8_t)k);
      snprintf(msg, sizeof msg, "%s: n=%u ch=%d level=%d", what, n, ch, k);
      TEST_ASSERT_EQUAL_UINT32_MESSAGE(r.pairs, allan_pairs(&eng, (uint8_t)k), msg);
      TEST_ASSERT_EQUAL_HEX8_MESSAGE(r.flags, flags, msg);
      if (r.flags & ALLAN_FLAG_SAT)
        TEST_ASSERT_TRUE_MESSAGE(engine_acc(ch, k) == ACC_MAX(k), msg);
      if (r.flags)
        continue;
      TEST_ASSERT_TRUE_MESSAGE(engine_acc(ch, k) == r.sumsq, msg);
      if (r.pairs) {
        double m = (double)(1u << k);
        double avar = (double)engine_acc(ch, k) / (2.0 * m * m * r.pairs);
        double d = rel_diff(avar, r.avar);
        snprintf(msg, sizeof msg, "%s: ch=%d level=%d avar %.17g ref %.17g rel %.3g", what, ch, k, avar,
                 r.avar, d);
        TEST_ASSERT_TRUE_MESSAGE(d <= 1e-12, msg);
      }
      exact++;
    }
  }
  return exact;
}

/* ---- stream generators: each channel gets its own flavour ---- */
enum { S_RANDOM, S_CONSTANT, S_RAMP, S_SQUARE, S_WALK, S_IMU };

static void fill(uint16_t *x, uint32_t n, int kind, uint64_t seed)
{
  rng_seed(seed);
  for (int ch = 0; ch < NCH; ch++) {
    double walk = 200.0 + 100.0 * ch, gm = 0.0;
    uint16_t konst = (uint16_t)(ch == 0 ? 0u : ch == 1 ? ALLAN_CODE_MAX : 497u + (unsigned)ch);
    for (uint32_t i = 0; i < n; i++) {
      uint16_t v;
      switch (kind) {
      case S_RANDOM: v = (uint16_t)rng_below(ALLAN_CODE_MAX + 1); break;
      case S_CONSTANT: v = konst; break;
      case S_RAMP:
        v = (uint16_t)(((uint64_t)i * (ALLAN_CODE_MAX + 1) / n + ch * 37) % (ALLAN_CODE_MAX + 1));
        break;
      case S_SQUARE: /* full scale, half period 2^(14-ch): level 14 and below see huge steps */
        v = ((i >> (14 - ch)) & 1) ? ALLAN_CODE_MAX : 0;
        break;
      case S_WALK: /* reflecting random walk over the whole code range */
        walk += rng_gauss() * (1.0 + ch);
        if (walk < 0)
          walk = -walk;
        if (walk > ALLAN_CODE_MAX)
          walk = 2.0 * ALLAN_CODE_MAX - walk;
        v = clamp_code(walk);
        break;
      default: /* thesis-like sensor at rest: offset + white + Gauss-Markov bias */
        gm = 0.999 * gm + 0.05 * rng_gauss();
        v = clamp_code(496.0 + 60 * ch + 2.0 * rng_gauss() + gm);
        break;
      }
      x[(size_t)i * NCH + ch] = v;
    }
  }
}

static void run_stream(int kind, uint32_t n, uint64_t seed, const char *what)
{
  uint16_t *x = rows(n);
  fill(x, n, kind, seed);
  allan_reset(&eng);
  push_all(x, n);
  check_all(x, n, what);
}

/* ---- tests ---- */
#define N_STREAM (1u << 17)

void setUp(void)
{
  allan_reset(&eng);
}
void tearDown(void) {}

static void test_state_is_packed(void)
{
  /* 7 bytes per channel-level, an eighth for the sum above m = 64, a ninth
   * for 48-bit levels, the code range only where wide levels need it, and
   * the sample count, the cascade's depth, and one bit
   * per level whose pairs may wait (levels 2 .. NLEV-2). */
  size_t expect = NCH * (7u * NLEV + (NLEV - 7u) + (NLEV - ALLAN_ACC48_FROM) + (NLEV > 15 ? 4u : 0u)) + 5u +
                  (NLEV - 2 > 16 ? 4u : 2u);
  TEST_ASSERT_EQUAL_UINT32(7, sizeof(allan_cell_t));
  TEST_ASSERT_EQUAL_UINT32(expect, ALLAN_STATE_BYTES);
  TEST_ASSERT_TRUE(sizeof eng >= expect && sizeof eng <= expect + 7); /* + host alignment */
}

static void test_random_stream(void)
{
  run_stream(S_RANDOM, N_STREAM, 1, "random");
}
static void test_constant_stream(void)
{
  run_stream(S_CONSTANT, N_STREAM, 2, "constant");
}
static void test_ramp_stream(void)
{
  run_stream(S_RAMP, N_STREAM + 12345, 3, "ramp");
}
static void test_random_walk_stream(void)
{
  run_stream(S_WALK, N_STREAM + 777, 4, "walk");
}
static void test_imu_like_stream(void)
{
  run_stream(S_IMU, N_STREAM, 5, "imu");
}

static void test_square_wave_saturates_exactly_where_due(void)
{
  uint16_t *x = rows(N_STREAM);
  fill(x, N_STREAM, S_SQUARE, 6);
  allan_reset(&eng);
  push_all(x, N_STREAM);
  check_all(x, N_STREAM, "square");
  /* Channel 0 toggles every 16384 samples: every level-14 difference is
   * 1023*16384, whose square fits 48 bits once but not twice. */
  if (NLEV > 14)
    TEST_ASSERT_EQUAL_HEX8(ALLAN_FLAG_SAT, allan_flags(&eng, 0, 14) & ALLAN_FLAG_SAT);
  TEST_ASSERT_EQUAL_HEX8(0, allan_flags(&eng, 0, 12));
}

/* A full-scale step at level k has |dS| = 1023 * 2^k: its square fits the
 * level's accumulator once (1023/1024 < 1) but not twice, for 40-bit level
 * 10 and 48-bit level 14 alike.  Checked on every channel, exactly. */
static void saturation_boundary(uint8_t k)
{
  const uint32_t m = 1u << k;
  const unsigned __int128 step = (unsigned __int128)1023u * m;
  uint16_t *x = rows(3 * m);
  for (uint32_t i = 0; i < 3 * m; i++)
    for (int ch = 0; ch < NCH; ch++)
      x[(size_t)i * NCH + ch] = (i / m == 1) ? ALLAN_CODE_MAX : 0;
  allan_reset(&eng);
  push_all(x, 2 * m);
  TEST_ASSERT_EQUAL_UINT32(1, allan_pairs(&eng, k));
  TEST_ASSERT_EQUAL_HEX8(0, allan_flags(&eng, 3, k));
  TEST_ASSERT_TRUE(engine_acc(3, k) == step * step);
  TEST_ASSERT_TRUE(step * step * 2 > ACC_MAX(k));
  push_all(x + (size_t)2 * m * NCH, m);
  TEST_ASSERT_EQUAL_HEX8(ALLAN_FLAG_SAT, allan_flags(&eng, 3, k));
  TEST_ASSERT_TRUE(engine_acc(3, k) == ACC_MAX(k));
  check_all(x, 3 * m, "boundary");
}

static void test_saturation_boundary_one_pair_fits_two_do_not(void)
{
  if (ALLAN_ACC_BITS(10) == 40)
    saturation_boundary(10);
  saturation_boundary(14);
}

static void test_pair_counts_follow_sample_count(void)
{
  uint16_t s[NCH] = {1, 2, 3, 4, 5, 6};
  for (uint32_t n = 1; n <= 70000; n++) {
    TEST_ASSERT_EQUAL_UINT8(ALLAN_OK, allan_push(&eng, s));
    if (n % 997 == 0 || n < 40 || (n & (n - 1)) == 0) {
      for (int k = 0; k < NLEV; k++) {
        uint32_t clusters = n / (1u << k);
        TEST_ASSERT_EQUAL_UINT32(clusters >= 2 ? clusters - 1 : 0, allan_pairs(&eng, (uint8_t)k));
      }
    }
  }
}

/* allan_begin + allan_channel (the firmware's way) leave exactly the state
 * allan_push leaves. */
static void test_piecewise_push_matches_push(void)
{
  static allan_t other;
  uint16_t *x = rows(50000);
  fill(x, 50000, S_WALK, 12);
  allan_reset(&eng);
  allan_reset(&other);
  for (uint32_t i = 0; i < 50000; i++) {
    const uint16_t *set = &x[(size_t)i * NCH];
    TEST_ASSERT_EQUAL_UINT8(ALLAN_OK, allan_push(&eng, set));
    TEST_ASSERT_EQUAL_UINT8(ALLAN_OK, allan_begin(&other));
    for (uint8_t ch = 0; ch < NCH; ch++)
      allan_channel(&other, ch, set[ch]);
  }
  TEST_ASSERT_EQUAL_MEMORY(&eng, &other, sizeof eng);
  check_all(x, 50000, "piecewise");
}

/* Pairs wait a few sets after a deep cascade (docs/allan-engine.md): a
 * read between any two sets must still cover exactly allan_pairs() pairs.
 * Reads right after every deep cascade and at a rotating level elsewhere,
 * each checked against the reference over the first n sets. */
static void test_reads_between_any_two_sets_are_exact(void)
{
  const uint32_t n = 9000;
  char msg[96];
  uint16_t *x = rows(n);
  fill(x, n, S_WALK, 21);
  allan_reset(&eng);
  for (uint32_t i = 1; i <= n; i++) {
    TEST_ASSERT_EQUAL_UINT8(ALLAN_OK, allan_push(&eng, &x[(size_t)(i - 1) * NCH]));
    if ((i & 63u) != 0 && i % 97u != 0)
      continue;
    for (int t = 0; t < 3; t++) {
      int ch = (int)((i / 64u + (uint32_t)t) % NCH), k = (int)((i / 97u + (uint32_t)t * 5u) % 14u);
      ref_t r = reference(x, i, ch, k);
      snprintf(msg, sizeof msg, "read after n=%u ch=%d level=%d", i, ch, k);
      TEST_ASSERT_EQUAL_UINT32_MESSAGE(r.pairs, allan_pairs(&eng, (uint8_t)k), msg);
      TEST_ASSERT_TRUE_MESSAGE(engine_acc(ch, k) == r.sumsq, msg);
    }
  }
  check_all(x, n, "reads");
}

/* Reading (which takes waiting pairs early) leaves the same engine as not
 * reading, once both have taken every waiting pair. */
static void test_reading_early_changes_nothing(void)
{
  static allan_t quiet;
  uint16_t hi;
  uint32_t lo;
  uint16_t *x = rows(40000);
  fill(x, 40000, S_IMU, 22);
  allan_reset(&eng);
  allan_reset(&quiet);
  for (uint32_t i = 0; i < 40000; i++) {
    TEST_ASSERT_EQUAL_UINT8(ALLAN_OK, allan_push(&eng, &x[(size_t)i * NCH]));
    TEST_ASSERT_EQUAL_UINT8(ALLAN_OK, allan_push(&quiet, &x[(size_t)i * NCH]));
    if (i % 5u == 0)
      allan_acc(&eng, (uint8_t)(i % NCH), (uint8_t)(i % NLEV), &hi, &lo);
    if (i % 1001u == 0)
      allan_settle_level(&eng, (uint8_t)(i % NLEV));
  }
  TEST_ASSERT_TRUE(quiet.pend != 0 || eng.pend == 0); /* 40000 = 2^6 * 625: pairs wait */
  allan_settle(&eng);
  allan_settle(&quiet);
  TEST_ASSERT_EQUAL_HEX32(0, eng.pend);
  TEST_ASSERT_EQUAL_MEMORY(&quiet, &eng, sizeof eng);
  check_all(x, 40000, "early reads");
}

/* Lagging channels (docs/allan-engine.md, "Spreading the cascade"): a set
 * that completes ALLAN_LAG_DEPTH levels or more leaves the levels 2 and up
 * of channels ALLAN_LAG_FROM.. to the next set, their state parked in the
 * spare bits of levels 0 and 1.  Right after every such set, every channel
 * and level read must equal the reference over the sets pushed so far
 * (flags included: full-scale squares saturate, and park 2046, every
 * parked bit); the reads go through a copy, so that the engine pushed on
 * never catches up early and each lag is taken by the next set. */
static void test_reads_right_after_a_lagging_set_are_exact(void)
{
  static allan_t copy;
  static const int kinds[] = {S_WALK, S_SQUARE, S_RANDOM};
  const uint32_t n = 4096 + 24; /* up to a 13-level cascade */
  char msg[96];
  uint16_t *x = rows(n);
  for (int kind = 0; kind < 3; kind++) {
    uint32_t lagging = 0;
    fill(x, n, kinds[kind], 40u + (uint64_t)kind);
    allan_reset(&eng);
    for (uint32_t i = 1; i <= n; i++) {
      TEST_ASSERT_EQUAL_UINT8(ALLAN_OK, allan_push(&eng, &x[(size_t)(i - 1) * NCH]));
      if (!(eng.depth & ALLAN_LAGGING))
        continue;
      lagging++;
      for (int ch = 0; ch < NCH; ch++)
        for (int k = 0; k < NLEV; k++) {
          ref_t r = reference(x, i, ch, k);
          uint16_t hi;
          uint32_t lo;
          memcpy(&copy, &eng, sizeof eng);
          allan_acc(&copy, (uint8_t)ch, (uint8_t)k, &hi, &lo);
          snprintf(msg, sizeof msg, "lagging n=%u ch=%d level=%d", i, ch, k);
          TEST_ASSERT_EQUAL_HEX8_MESSAGE(r.flags, allan_flags(&copy, (uint8_t)ch, (uint8_t)k), msg);
          if (!r.flags)
            TEST_ASSERT_TRUE_MESSAGE((((unsigned __int128)hi << 32) | lo) == r.sumsq, msg);
        }
    }
    /* one set in 2^(ALLAN_LAG_DEPTH-1) lags */
    TEST_ASSERT_EQUAL_UINT32(n >> (ALLAN_LAG_DEPTH - 1u), lagging);
    check_all(x, n, "after lagging sets");
  }
}

/* A reset while channels lag forgets them: the engine is a fresh one. */
static void test_reset_while_channels_lag_starts_afresh(void)
{
  static allan_t fresh;
  uint16_t *x = rows(3000);
  fill(x, 1024, S_RANDOM, 31);
  allan_reset(&eng);
  push_all(x, 1024); /* 1024 completes 11 levels: channels lag */
  TEST_ASSERT_TRUE((eng.depth & ALLAN_LAGGING) && eng.pend);
  allan_reset(&eng);
  allan_reset(&fresh);
  TEST_ASSERT_EQUAL_MEMORY(&fresh, &eng, sizeof eng);
  fill(x, 3000, S_WALK, 32);
  push_all(x, 3000);
  check_all(x, 3000, "reset while lagging");
}

static void test_bad_code_is_refused_and_changes_nothing(void)
{
  uint16_t ok[NCH] = {500, 501, 502, 503, 504, 505};
  uint16_t bad[NCH] = {500, 501, 502, 1024, 504, 505};
  allan_t before;
  for (int i = 0; i < 100; i++) {
    ok[0] = (uint16_t)(500 + i % 7);
    allan_push(&eng, ok);
  }
  memcpy(&before, &eng, sizeof eng);
  TEST_ASSERT_EQUAL_UINT8(ALLAN_ERR_CODE, allan_push(&eng, bad));
  TEST_ASSERT_EQUAL_MEMORY(&before, &eng, sizeof eng);
}

static void test_full_counter_is_refused(void)
{
  uint16_t s[NCH] = {0};
  allan_t before;
  /* 2^32 pushes take too long for a unit test: set the counter directly. */
  eng.n = 0xFFFFFFFFul;
  memcpy(&before, &eng, sizeof eng);
  TEST_ASSERT_EQUAL_UINT8(ALLAN_ERR_FULL, allan_push(&eng, s));
  TEST_ASSERT_EQUAL_MEMORY(&before, &eng, sizeof eng);
}

static void test_reset_forgets_everything(void)
{
  uint16_t *x = rows(N_STREAM);
  fill(x, 5000, S_RANDOM, 7);
  push_all(x, 5000);
  allan_reset(&eng);
  TEST_ASSERT_EQUAL_UINT32(0, eng.n);
  for (int ch = 0; ch < NCH; ch++)
    for (int k = 0; k < NLEV; k++) {
      TEST_ASSERT_TRUE(engine_acc(ch, k) == 0);
      TEST_ASSERT_EQUAL_HEX8(0, allan_flags(&eng, (uint8_t)ch, (uint8_t)k));
    }
  fill(x, N_STREAM, S_WALK, 8);
  push_all(x, N_STREAM);
  check_all(x, N_STREAM, "after reset");
}

/* Many seeds, random lengths (including 0..3) and random stream shapes. */
static void test_property_many_seeds(void)
{
  const uint32_t max_n = 40000;
  uint16_t *x = rows(max_n);
  int exact = 0;
  for (uint64_t seed = 100; seed < 300; seed++) {
    uint32_t n;
    rng_seed(seed);
    n = seed < 104 ? (uint32_t)(seed - 100) : 1 + rng_below(max_n);
    for (int ch = 0; ch < NCH; ch++) {
      double center = rng_below(1024), sd = rng_below(5) ? rng_below(40) * 0.25 : 300.0;
      double step = rng_below(3) ? 0.0 : rng_below(100) * 0.05, w = center;
      for (uint32_t i = 0; i < n; i++) {
        w += step * rng_gauss();
        if (w < 0 || w > ALLAN_CODE_MAX)
          w = center;
        x[(size_t)i * NCH + ch] = clamp_code(w + sd * rng_gauss());
      }
    }
    allan_reset(&eng);
    push_all(x, n);
    exact += check_all(x, n, "property");
  }
  TEST_ASSERT_TRUE(exact > 200 * NCH * 10);
}

#if ALLAN_LEVELS > 15
/* Wide levels: a narrow channel stays exact up to the top level, a
 * full-range one is flagged RANGE from the level where the bound breaks. */
static void test_wide_levels_exact_when_range_is_narrow(void)
{
  const uint32_t n = 1u << NLEV; /* two clusters at the top level */
  uint16_t *x = rows(n + 4321);
  rng_seed(9);
  for (int ch = 0; ch < NCH; ch++) {
    /* ch 0: range 8, top levels fine; ch 5: full range, flagged from 15 */
    int span = ch == 5 ? 1024 : 8 << ch;
    for (uint32_t i = 0; i < n + 4321; i++)
      x[(size_t)i * NCH + ch] = (uint16_t)(ch == 5 ? rng_below(1024) : 300 + rng_below((uint32_t)span));
  }
  allan_reset(&eng);
  push_all(x, n + 4321);
  TEST_ASSERT_EQUAL_HEX8(0, allan_flags(&eng, 0, NLEV - 1));
  TEST_ASSERT_EQUAL_HEX8(ALLAN_FLAG_RANGE, allan_flags(&eng, 5, 15) & ALLAN_FLAG_RANGE);
  TEST_ASSERT_EQUAL_HEX8(0, allan_flags(&eng, 5, 14));
  TEST_ASSERT_TRUE(check_all(x, n + 4321, "wide") > NCH * 15);
}

/* Sums that wrap 2^24 many times must still give exact differences. */
static void test_wide_levels_wrap_modulo_but_stay_exact(void)
{
  const uint32_t n = 3u << (NLEV - 1);
  uint16_t *x = rows(n);
  for (uint32_t i = 0; i < n; i++)
    for (int ch = 0; ch < NCH; ch++)
      x[(size_t)i * NCH + ch] = (uint16_t)(1015 + ((i * 7u + (uint32_t)ch) % 9)); /* 1015..1023 */
  allan_reset(&eng);
  push_all(x, n);
  check_all(x, n, "wrap");
  TEST_ASSERT_EQUAL_HEX8(0, allan_flags(&eng, 0, NLEV - 1));
}
#endif

int main(void)
{
  UNITY_BEGIN();
  RUN_TEST(test_state_is_packed);
  RUN_TEST(test_random_stream);
  RUN_TEST(test_constant_stream);
  RUN_TEST(test_ramp_stream);
  RUN_TEST(test_random_walk_stream);
  RUN_TEST(test_imu_like_stream);
  RUN_TEST(test_square_wave_saturates_exactly_where_due);
  RUN_TEST(test_saturation_boundary_one_pair_fits_two_do_not);
  RUN_TEST(test_pair_counts_follow_sample_count);
  RUN_TEST(test_piecewise_push_matches_push);
  RUN_TEST(test_reads_between_any_two_sets_are_exact);
  RUN_TEST(test_reading_early_changes_nothing);
  RUN_TEST(test_reads_right_after_a_lagging_set_are_exact);
  RUN_TEST(test_reset_while_channels_lag_starts_afresh);
  RUN_TEST(test_bad_code_is_refused_and_changes_nothing);
  RUN_TEST(test_full_counter_is_refused);
  RUN_TEST(test_reset_forgets_everything);
  RUN_TEST(test_property_many_seeds);
#if ALLAN_LEVELS > 15
  RUN_TEST(test_wide_levels_exact_when_range_is_narrow);
  RUN_TEST(test_wide_levels_wrap_modulo_but_stay_exact);
#endif
  free(buf);
  return UNITY_END();
}
