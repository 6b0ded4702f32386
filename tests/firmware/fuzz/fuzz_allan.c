/*
 * fuzz_allan - the Allan engine (firmware/allan.c) against an exact
 * reference kept here: every cluster sum is a difference of the running
 * total of the samples (prefix sums: no cascade, no 24-bit wrap), squared
 * differences accumulated exactly in unsigned __int128, the code range
 * tracked for the RANGE bound, SAT at the level's width ALLAN_ACC_BITS(level).
 * The reference is updated as the samples arrive (a level's two latest
 * boundaries only), so that a push costs it as little as it costs the engine.
 * Built with the default configuration (fuzz_allan) and with
 * -DALLAN_LEVELS=20 -DALLAN_ACC48_FROM=0 (fuzz_allan20, the ATmega328P's).
 *
 * Speed is coverage: an input pushes at most MAX_PUSH sets, and may start
 * from a snapshot instead of an empty engine.  The snapshots are taken once
 * per process, by pushing a few fixed signals (PATTERNS) through the engine
 * and the reference together, just before the sample counts where levels
 * 8 .. ALLAN_LEVELS-1 complete their first pair (2^(k+1)): so a short
 * input reaches the high levels, the 48-bit accumulators' saturation and
 * the wide levels' range bound, which take up to a million sets from an
 * empty engine.
 *
 * Input: byte 0 picks the start (0: an empty engine, else a snapshot), then
 * records of 14 bytes: a header h, an action r and 6 little-endian codes.
 *   h & 0x0F, bit 7: the record is pushed (h&15)+1 times, or 2^(h&15) times
 *                    when bit 7 is set;
 *   (h >> 4) & 3:    0 the same codes each time, 1 alternating with
 *                    1023 - code (full-scale square waves), 2 a ramp
 *                    (code + i mod 1024), 3 the code plus noise -4..+3
 *                    (clamped), from a generator seeded by the record;
 *   bit 6 of h:      the sets go through allan_begin() + allan_channel()
 *                    (the firmware's path) instead of allan_push();
 *   a 16-bit value v gives code v & 1023, except when v >> 10 is 63: then
 *   1024 + (v & 1023) (0xFFFF for 1023), out of range, which must be refused
 *   with ALLAN_ERR_CODE and leave the engine's state byte for byte as it was.
 *   r >> 5, what is read (reading takes waiting work, so when it happens
 *   changes the engine's schedule: the input decides, as the report does):
 *     1 after the record, level (r & 31) mod ALLAN_LEVELS of every channel;
 *     2 after the record, every channel and level;
 *     3 after the record, (r & 31) + 1 calls of allan_settle_some();
 *     4 after the record, allan_settle();
 *     5 during the record, after every set, the levels it completed;
 *     else nothing.
 * After every push the sample count is checked, and at the end every channel
 * and level (pairs, flags, accumulator): accumulators must be exact whenever
 * SAT is not set (RANGE alone included: pairs taken before the bound broke
 * are exact), and exactly the maximum when it is.  Last, a counter at
 * 2^32 - 1 must refuse the next set (ALLAN_ERR_FULL) from allan_push() and
 * allan_begin() alike, leaving the state as it was.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "allan.h"
#include "fuzz_util.h"

#define NCH ALLAN_CHANNELS
#define NLEV ALLAN_LEVELS
/* Sets an input may push: a thousand (levels up to 9 from an empty engine)
 * keep a run at thousands of inputs a second of CPU; the snapshots bring
 * the levels beyond within reach. */
#ifndef MAX_PUSH
#  define MAX_PUSH 1024ul
#endif
/* A snapshot is taken this many sets before the count it leads to. */
#define LEAD 24u
#define ACC_MAX(level) ((((unsigned __int128)1) << ALLAN_ACC_BITS(level)) - 1)

typedef unsigned __int128 u128;

/* The reference's own branches are no coverage of the engine's: left out
 * of the fuzzer's guidance, and of its cost. */
#define REF_ONLY __attribute__((no_sanitize("coverage")))

typedef struct {
  uint32_t n;
  uint16_t lo[NCH], hi[NCH];    /* code range so far */
  int64_t total[NCH];           /* sum of all samples */
  int64_t at1[NCH][NLEV];       /* total at level k's last boundary */
  int64_t at2[NCH][NLEV];       /*          and at the one before it */
  uint32_t clusters[NLEV];      /* complete clusters: n >> level */
  u128 acc[NCH][NLEV];          /* sum of squared differences, exact */
  uint8_t range_hit[NCH][NLEV]; /* a pair taken with the bound broken */
} ref_t;

static ref_t ref;

REF_ONLY static void ref_reset(void)
{
  memset(&ref, 0, sizeof ref);
  for (int ch = 0; ch < NCH; ch++)
    ref.lo[ch] = ALLAN_CODE_MAX;
}

REF_ONLY static int bound_broken(int ch, int k)
{
  /* |dS| < 2^23 proven by (max - min) * m < 2^23, needed from level 15 */
  return k >= 15 && ref.n && (uint64_t)(ref.hi[ch] - ref.lo[ch]) * (1ull << k) >= (1ull << 23);
}

REF_ONLY static void ref_push(const uint16_t *code)
{
  uint32_t n = ++ref.n;
  for (int ch = 0; ch < NCH; ch++) {
    ref.total[ch] += code[ch];
    if (code[ch] < ref.lo[ch])
      ref.lo[ch] = code[ch];
    if (code[ch] > ref.hi[ch])
      ref.hi[ch] = code[ch];
  }
  /* Sample n completes a cluster at every level k with 2^k | n: the
   * cluster's sum is the total now minus the total at its start. */
  for (int k = 0; k < NLEV && n % (1ul << k) == 0; k++) {
    for (int ch = 0; ch < NCH; ch++) {
      if (ref.clusters[k]) { /* a pair: this cluster and the one before */
        int64_t s = ref.total[ch] - ref.at1[ch][k], prev = ref.at1[ch][k] - ref.at2[ch][k];
        uint64_t d = (uint64_t)(s > prev ? s - prev : prev - s);
        ref.acc[ch][k] += (u128)d * d;
        if (bound_broken(ch, k))
          ref.range_hit[ch][k] = 1;
      }
      ref.at2[ch][k] = ref.at1[ch][k];
      ref.at1[ch][k] = ref.total[ch];
    }
    ref.clusters[k]++;
  }
}

static void check_cell(allan_t *a, int ch, int k)
{
  uint16_t hi;
  uint32_t lo;
  u128 got;
  uint8_t want = 0, flags = allan_flags(a, (uint8_t)ch, (uint8_t)k);
  uint32_t pairs = ref.clusters[k] >= 2 ? ref.clusters[k] - 1 : 0;
  if (bound_broken(ch, k))
    want |= ALLAN_FLAG_RANGE;
  if (ref.range_hit[ch][k] || ref.acc[ch][k] >= ACC_MAX(k))
    want |= ALLAN_FLAG_SAT;
  allan_acc(a, (uint8_t)ch, (uint8_t)k, &hi, &lo);
  got = (u128)hi << 32 | lo;
  FUZZ_CHECK(allan_pairs(a, (uint8_t)k) == pairs, "n=%u level %d: pairs %u, expected %u", ref.n, k,
             allan_pairs(a, (uint8_t)k), pairs);
  FUZZ_CHECK(flags == want, "n=%u ch %d level %d: flags %02X, expected %02X", ref.n, ch, k, flags, want);
  FUZZ_CHECK(got == ((want & ALLAN_FLAG_SAT) ? ACC_MAX(k) : ref.acc[ch][k]),
             "n=%u ch %d level %d: acc %04X%08X, expected 0x%llx (flags %02X)", ref.n, ch, k, hi, lo,
             (unsigned long long)((want & ALLAN_FLAG_SAT) ? ACC_MAX(k) : ref.acc[ch][k]), want);
}

static void check_level(allan_t *a, int k)
{
  for (int ch = 0; ch < NCH; ch++)
    check_cell(a, ch, k);
}

static void check_all(allan_t *a)
{
  for (int k = 0; k < NLEV; k++)
    check_level(a, k);
}

REF_ONLY static uint16_t clamp(int v)
{
  return (uint16_t)(v < 0 ? 0 : v > (int)ALLAN_CODE_MAX ? (int)ALLAN_CODE_MAX : v);
}

static void push_both(allan_t *a, const uint16_t *code, int split)
{
  uint8_t r;
  if (split) { /* the firmware's path: a channel at a time */
    r = allan_begin(a);
    if (r == ALLAN_OK)
      for (int ch = 0; ch < NCH; ch++)
        allan_channel(a, (uint8_t)ch, code[ch]);
  } else {
    r = allan_push(a, code);
  }
  FUZZ_CHECK(r == ALLAN_OK, "n=%u: push refused with %u", ref.n, r);
  ref_push(code);
  FUZZ_CHECK(a->n == ref.n, "sample count %u, expected %u", a->n, ref.n);
}

/* The snapshots' signals, a code for channel ch at sample i. */
#define PATTERNS 3
REF_ONLY static uint16_t pattern_code(int p, int ch, uint32_t i)
{
  uint32_t h = (i + 1u) * 2654435761u ^ (uint32_t)ch * 40503u;
  h ^= h >> 15;
  switch (p) {
  case 0: /* a channel each: constant low, constant high, quiet noise,
           * full-scale square per sample, blocks of 2^12, ramp */
    switch (ch % 6) {
    case 0: return 0;
    case 1: return ALLAN_CODE_MAX;
    case 2: return (uint16_t)(500 + (h & 7));
    case 3: return (i & 1) ? ALLAN_CODE_MAX : 0;
    case 4: return (i >> 12 & 1) ? ALLAN_CODE_MAX : 0;
    default: return (uint16_t)(i & 1023);
    }
  case 1: /* quiet: a range of 63 codes, exact up to level 17 */
    return (uint16_t)(480 + ch + (h & 31) + (i >> 14 & 31));
  default: /* blocks of 2^(8+ch), full scale: large high-level differences */
    return (i >> (8 + ch) & 1) ? ALLAN_CODE_MAX : 0;
  }
}

typedef struct {
  allan_t a;
  ref_t r;
} snapshot_t;

#define POINTS (NLEV - 8) /* 2^(k+1) for k = 8 .. NLEV-1 */
static snapshot_t *snap;
static size_t snaps;

REF_ONLY static uint32_t point(int j)
{
  return (1ul << (9 + j)) - LEAD;
}

REF_ONLY static void make_snapshots(void)
{
  allan_t *a = malloc(sizeof *a);
  snap = malloc(PATTERNS * POINTS * sizeof *snap); /* enough */
  for (int p = 0; p < PATTERNS; p++) {
    uint32_t i = 0;
    allan_reset(a);
    ref_reset();
    /* the full-scale blocks break the range bound at every wide level:
     * levels up to 15 show all they do */
    for (int j = 0; j < POINTS && (p < 2 || j <= 15 - 8); j++) {
      uint16_t code[NCH];
      for (; i < point(j); i++) {
        for (int ch = 0; ch < NCH; ch++)
          code[ch] = pattern_code(p, ch, i);
        push_both(a, code, (int)(i & 1));
      }
      snap[snaps].a = *a;
      snap[snaps].r = ref;
      snaps++;
    }
  }
  free(a);
}

/* Before the first input, so that what the snapshots cover is no input's. */
int LLVMFuzzerInitialize(int *argc, char ***argv)
{
  (void)argc;
  (void)argv;
  make_snapshots();
  return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  fuzz_in_t in = {data, size};
  allan_t *a = malloc(sizeof *a); /* exactly sized: ASan guards its ends */
  allan_t *before = malloc(sizeof *a);
  uint32_t start, pushed = 0;
  uint8_t pick;

  pick = fz_u8(&in);
  if (pick % (snaps + 1) == 0) {
    allan_reset(a);
    ref_reset();
    check_all(a);
  } else {
    *a = snap[pick % (snaps + 1) - 1].a;
    ref = snap[pick % (snaps + 1) - 1].r;
  }
  start = ref.n;
  while (in.n && pushed < MAX_PUSH) {
    uint8_t h = fz_u8(&in), r = fz_u8(&in), mode = (h >> 4) & 3u, act = r >> 5;
    uint32_t reps = (h & 0x80) ? 1ul << (h & 15) : (h & 15) + 1ul, i;
    uint16_t base[NCH], code[NCH];
    uint64_t rng = h;
    int bad = 0;
    for (int ch = 0; ch < NCH; ch++) {
      uint16_t v = fz_u16(&in);
      rng = rng * 0x9E3779B97F4A7C15ull + v;
      if ((v >> 10) == 63) {
        base[ch] = (v & 1023) == 1023 ? 0xFFFF : (uint16_t)(1024 + (v & 1023));
        bad = 1;
      } else {
        base[ch] = v & 1023;
      }
    }
    for (i = 0; i < reps && pushed < MAX_PUSH; i++) {
      for (int ch = 0; ch < NCH; ch++) {
        uint16_t c = base[ch];
        if (c <= ALLAN_CODE_MAX) {
          if (mode == 1 && (i & 1))
            c = (uint16_t)(ALLAN_CODE_MAX - c);
          else if (mode == 2)
            c = (uint16_t)((c + i) & 1023);
          else if (mode == 3) {
            rng = rng * 6364136223846793005ull + 1442695040888963407ull;
            c = clamp((int)c + (int)(rng >> 61) - 4);
          }
        }
        code[ch] = c;
      }
      if (bad) {
        uint8_t e;
        memcpy(before, a, sizeof *a);
        e = allan_push(a, code);
        FUZZ_CHECK(e == ALLAN_ERR_CODE, "n=%u: a code above %u gave %u, not ALLAN_ERR_CODE", ref.n,
                   ALLAN_CODE_MAX, e);
        FUZZ_CHECK(memcmp(before, a, sizeof *a) == 0, "n=%u: a refused push changed the state", ref.n);
        break; /* the same codes would be refused again */
      }
      push_both(a, code, h & 0x40);
      pushed++;
      if (act == 5)
        for (int k = 0; k < NLEV && (ref.n & ((1ul << k) - 1)) == 0; k++)
          check_level(a, k);
    }
    if (act == 1)
      check_level(a, (r & 31) % NLEV);
    else if (act == 2)
      check_all(a);
    else if (act == 3)
      for (int j = 0; j <= (r & 31) && allan_settle_some(a); j++)
        ;
    else if (act == 4)
      allan_settle(a);
  }
  FUZZ_CHECK(ref.n == start + pushed, "pushed %u from %u, at %u", pushed, start, ref.n);
  check_all(a);

  /* A full sample counter refuses the set, by either path, untouched. */
  {
    static const uint16_t zero[NCH];
    a->n = 0xFFFFFFFFul;
    memcpy(before, a, sizeof *a);
    FUZZ_CHECK(allan_push(a, zero) == ALLAN_ERR_FULL, "a full counter did not refuse a push");
    FUZZ_CHECK(allan_begin(a) == ALLAN_ERR_FULL, "a full counter did not refuse allan_begin");
    FUZZ_CHECK(memcmp(before, a, sizeof *a) == 0, "a refused push changed the state");
  }
  free(a);
  free(before);
  return 0;
}
