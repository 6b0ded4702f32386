/*
 * fuzz_allan - the Allan engine (firmware/allan.c) against a straightforward
 * reference kept here: every cluster sum taken from prefix sums of the
 * samples (no cascade), squared
 * differences accumulated exactly in unsigned __int128, code range tracked
 * for the RANGE bound, SAT at the level's width ALLAN_ACC_BITS(level).
 * Built with the default configuration (fuzz_allan) and with
 * -DALLAN_LEVELS=20 -DALLAN_ACC48_FROM=0 (fuzz_allan20, the ATmega328P's).
 *
 * Input: records of 13 bytes, a header h and 6 little-endian 16-bit codes.
 *   h & 0x0F, bit 7: the record is pushed (h&15)+1 times, or 2^(h&15) times
 *                    when bit 7 is set (up to 32768: high levels, saturation);
 *   (h >> 4) & 3:    0 the same codes each time, 1 alternating with
 *                    1023 - code (full-scale square waves), 2 a ramp
 *                    (code + i mod 1024), 3 the code plus noise -4..+3
 *                    (clamped), from a generator seeded by the record;
 *   a 16-bit value v gives code v & 1023, except when v >> 10 is 63: then
 *   1024 + (v & 1023) (0xFFFF for 1023), out of range, which must be refused
 *   with ALLAN_ERR_CODE and leave the engine's state byte for byte as it was.
 * At most MAX_PUSH sample sets per input.  Bit 6 of h feeds the record's
 * sets through allan_begin() + allan_channel() instead of allan_push().
 *
 * After every push: the sample count; for every channel the levels where a
 * cluster just completed (the only ones a push may change), and every
 * channel and level (pairs, flags, accumulator) after each of the first 4096
 * pushes, every 256th and the last of each record.  Accumulators must be
 * exact whenever SAT is not set (RANGE alone included: pairs taken before
 * the bound broke are exact), and exactly the maximum when it is.  At the
 * end, a counter at 2^32 - 1 must refuse the next set (ALLAN_ERR_FULL) from
 * allan_push() and allan_begin() alike, leaving the state as it was.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "allan.h"
#include "fuzz_util.h"

#define NCH ALLAN_CHANNELS
#define NLEV ALLAN_LEVELS
/* Enough sample sets for pairs at level 16 (20 levels) or saturation at
 * level 14 (15 levels), no more: the run's speed is set by the longest. */
#ifndef MAX_PUSH
#  define MAX_PUSH (ALLAN_LEVELS > 15 ? 1ul << 17 : 1ul << 16)
#endif
#define ACC_MAX(level) ((((unsigned __int128)1) << ALLAN_ACC_BITS(level)) - 1)

typedef unsigned __int128 u128;

/* Prefix sums of every channel: a cluster sum is P[end] - P[start]. */
static int64_t prefix[MAX_PUSH + 1][NCH];

static struct {
  uint32_t n;
  uint16_t lo[NCH], hi[NCH];          /* code range so far */
  uint32_t clusters[NLEV];            /* complete clusters: n >> level */
  u128 acc[NCH][NLEV];                /* sum of squared differences, exact */
  uint8_t range_hit[NCH][NLEV];       /* a pair taken with the bound broken */
} ref;

static void ref_reset(void)
{
  memset(&ref, 0, sizeof ref);
  for (int ch = 0; ch < NCH; ch++)
    ref.lo[ch] = ALLAN_CODE_MAX;
}

static int bound_broken(int ch, int k)
{
  /* |dS| < 2^23 proven by (max - min) * m < 2^23, needed from level 15 */
  return k >= 15 && ref.n && (uint64_t)(ref.hi[ch] - ref.lo[ch]) * (1ull << k) >= (1ull << 23);
}

static void ref_push(const uint16_t *code)
{
  uint32_t n = ++ref.n;
  for (int ch = 0; ch < NCH; ch++) {
    prefix[n][ch] = prefix[n - 1][ch] + code[ch];
    if (code[ch] < ref.lo[ch]) ref.lo[ch] = code[ch];
    if (code[ch] > ref.hi[ch]) ref.hi[ch] = code[ch];
  }
  /* Sample n completes a cluster at every level k with 2^k | n. */
  for (int k = 0; k < NLEV && n % (1ul << k) == 0; k++) {
    uint32_t m = 1ul << k;
    if (ref.clusters[k]) /* a pair: this cluster and the one before */
      for (int ch = 0; ch < NCH; ch++) {
        int64_t s = prefix[n][ch] - prefix[n - m][ch], prev = prefix[n - m][ch] - prefix[n - 2 * m][ch];
        uint64_t d = (uint64_t)(s > prev ? s - prev : prev - s);
        ref.acc[ch][k] += (u128)d * d;
        if (bound_broken(ch, k))
          ref.range_hit[ch][k] = 1;
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

static void check_all(allan_t *a)
{
  for (int ch = 0; ch < NCH; ch++)
    for (int k = 0; k < NLEV; k++)
      check_cell(a, ch, k);
}

static uint16_t clamp(int v)
{
  return (uint16_t)(v < 0 ? 0 : v > (int)ALLAN_CODE_MAX ? (int)ALLAN_CODE_MAX : v);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  fuzz_in_t in = {data, size};
  allan_t *a = malloc(sizeof *a); /* exactly sized: ASan guards its ends */
  allan_t *before = malloc(sizeof *a);

  allan_reset(a);
  ref_reset();
  check_all(a);
  while (in.n && ref.n < MAX_PUSH) {
    uint8_t h = fz_u8(&in), mode = (h >> 4) & 3u;
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
    for (i = 0; i < reps && ref.n < MAX_PUSH; i++) {
      uint8_t r;
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
        memcpy(before, a, sizeof *a);
        r = allan_push(a, code);
        FUZZ_CHECK(r == ALLAN_ERR_CODE, "n=%u: a code above %u gave %u, not ALLAN_ERR_CODE", ref.n,
                   ALLAN_CODE_MAX, r);
        FUZZ_CHECK(memcmp(before, a, sizeof *a) == 0, "n=%u: a refused push changed the state", ref.n);
        break; /* the same codes would be refused again */
      }
      if (h & 0x40) { /* the firmware's path: a channel at a time */
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
      if (ref.n <= 4096 || (ref.n & 255) == 0 || i + 1 == reps || ref.n == MAX_PUSH) {
        check_all(a);
      } else {
        for (int k = 0; k < NLEV && (ref.n & ((1ul << k) - 1)) == 0; k++)
          for (int ch = 0; ch < NCH; ch++)
            check_cell(a, ch, k);
      }
    }
  }
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
