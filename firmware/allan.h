/*
 * allan.h - exact, streaming, non-overlapping Allan variance at octave
 * cluster sizes, in integers, for ALLAN_CHANNELS channels of 10-bit codes.
 *
 * For every channel c and level k (cluster size m = 2^k) the engine keeps
 *   - the last complete cluster sum S (stored modulo 2^24; 2 bytes for
 *     m <= 64, where sums stay below 2^16, 3 bytes above), and
 *   - acc = sum over consecutive complete clusters of (S_j - S_{j-1})^2,
 *     saturating, 40 bits below level ALLAN_ACC48_FROM and 48 bits from it
 *     (5 or 6 bytes; see config.h for why),
 * so that the non-overlapping Allan variance in code^2 is
 *     avar = acc / (2 * m^2 * pairs),   pairs = floor(n / m) - 1,
 * exactly what allantools' adev computes at tau = m / fs.
 *
 * Pure module: no <avr/io.h>, builds natively for the unit tests.
 * Per sample: additions, compares and one 16x16 multiply per level visited;
 * the cascade visits level k once every 2^k samples (amortised < 2 levels
 * per channel), its worst case (all levels) once every 2^(L-1) samples.
 *
 * Exactness guarantees (see docs/allan-engine.md):
 *   - levels with ALLAN_CODE_MAX * m < 2^24 hold true cluster sums, so every
 *     difference is exact;
 *   - higher levels (only when ALLAN_LEVELS > 15) rely on |dS| < 2^23, which
 *     the channel's observed code range proves:  (max - min) * m < 2^23.
 *     Where that bound fails the level is flagged ALLAN_FLAG_RANGE and its
 *     accumulator saturates at its next pair;
 *   - an accumulator whose true sum would reach its maximum (2^40 - 1 or
 *     2^48 - 1) saturates there and is flagged ALLAN_FLAG_SAT.
 * A result without flags is exact.
 */
#ifndef ALLAN_H
#define ALLAN_H

#include <stdint.h>
#include "config.h"

/* First level whose cluster sums may not fit 24 bits (ALLAN_CODE_MAX*2^k >= 2^24). */
#define ALLAN_WIDE_LEVEL 15u
#define ALLAN_SUM_BITS 24u

/* Per-level result flags. */
#define ALLAN_FLAG_SAT 0x01u   /* accumulator saturated: true sum >= its maximum */
#define ALLAN_FLAG_RANGE 0x02u /* code range too wide for an exact 24-bit difference */

/* allan_push() return codes. */
#define ALLAN_OK 0u
#define ALLAN_ERR_CODE 1u /* a code above ALLAN_CODE_MAX: nothing was pushed */
#define ALLAN_ERR_FULL 2u /* sample counter at 2^32 - 1: nothing was pushed */

#if defined(__GNUC__) && !defined(__AVR__)
#  define ALLAN_PACKED __attribute__((packed))
#else
#  define ALLAN_PACKED /* the AVR has no alignment: structs are packed anyway */
#endif

/* Levels 0..ALLAN_NARROW_LEVELS-1 hold sums below 1023*64 < 2^16: two bytes
 * suffice.  Higher levels keep the sum's bits 16..23 in sum_hi[]. */
#define ALLAN_NARROW_LEVELS 7u

/* One channel-level: 7 bytes, plus one in sum_hi[] above the narrow levels
 * and one in acc_hi[] from level ALLAN_ACC48_FROM. */
typedef struct ALLAN_PACKED {
  uint16_t sum_lo; /* last complete cluster sum, bits 0..15 (mod 2^24) */
  uint32_t acc_lo; /* sum of squared differences, bits 0..31 */
  uint8_t acc_mid; /*                             bits 32..39 */
} allan_cell_t;

/* allan_t.depth: the levels the set in progress completes, and flags. */
#define ALLAN_DEPTH_MASK 0x3Fu
#define ALLAN_LAGGING 0x40u   /* some channels lag this set (allan.c, lag_park) */
#define ALLAN_TOP_FIRST 0x80u /* the top one has no pair yet */

/* Lagging channels: ALLAN_LAG_FROM and ALLAN_LAG_DEPTH, config.h. */

/* One bit per level whose pairs wait to be taken (allan.c, settle()):
 * levels 2 .. ALLAN_LEVELS-2 can wait. */
#if ALLAN_LEVELS > 17
typedef uint32_t allan_pend_t;
#else
typedef uint16_t allan_pend_t;
#endif

typedef struct {
  allan_cell_t cell[ALLAN_CHANNELS][ALLAN_LEVELS];
  uint8_t sum_hi[ALLAN_CHANNELS][ALLAN_LEVELS - ALLAN_NARROW_LEVELS];
  uint8_t acc_hi[ALLAN_CHANNELS][ALLAN_LEVELS - ALLAN_ACC48_FROM]; /* bits 40..47 */
#if ALLAN_LEVELS > ALLAN_WIDE_LEVEL
  /* Only wide levels need the code range (the 2^23 difference bound). */
  uint16_t min[ALLAN_CHANNELS]; /* smallest code seen (ALLAN_CODE_MAX before any) */
  uint16_t max[ALLAN_CHANNELS]; /* largest code seen (0 before any) */
#endif
  uint32_t n;        /* sample sets pushed */
  uint8_t depth;     /* levels the set in progress completes (allan_begin),
                                   | ALLAN_TOP_FIRST when the top one has no pair yet,
                                   | ALLAN_LAGGING while channels lag */
  allan_pend_t pend; /* levels whose pairs are deferred */
} allan_t;

/* Bytes of state for a build: what `avr-size` sees of the engine. */
#define ALLAN_STATE_BYTES                                                                                    \
  (ALLAN_CHANNELS * (7u * ALLAN_LEVELS + (ALLAN_LEVELS - ALLAN_NARROW_LEVELS) +                              \
                     (ALLAN_LEVELS - ALLAN_ACC48_FROM) + (ALLAN_LEVELS > ALLAN_WIDE_LEVEL ? 4u : 0u)) +      \
   5u + sizeof(allan_pend_t))

/* 1 when a level's accumulator has 48 bits (written so that a zero
 * ALLAN_ACC48_FROM draws no "always true" warning). */
#define ALLAN_IS_ACC48(level) ((unsigned)(level) + 1u > ALLAN_ACC48_FROM)
/* Width of a level's accumulator in bits: 40 or 48. */
#define ALLAN_ACC_BITS(level) (ALLAN_IS_ACC48(level) ? 48u : 40u)

/* Clear all accumulators and the sample count. */
void allan_reset(allan_t *a);

/* Feed one sample set (ALLAN_CHANNELS codes, 0..ALLAN_CODE_MAX).
 * Returns ALLAN_OK, or an ALLAN_ERR_* code with the state untouched. */
uint8_t allan_push(allan_t *a, const uint16_t code[ALLAN_CHANNELS]);

/* The same in pieces, for a caller that decodes codes one at a time (the
 * firmware's main loop, to keep its stack short): allan_begin() counts the
 * set (ALLAN_ERR_FULL: nothing counted, feed no channel), then
 * allan_channel() once for every channel, with a code the caller knows to
 * be 0..ALLAN_CODE_MAX (a 10-bit converter's). */
uint8_t allan_begin(allan_t *a);
void allan_channel(allan_t *a, uint8_t ch, uint16_t code);

/* Reading, between two sets (not between allan_begin() and the set's last
 * allan_channel()).  A level's pairs may wait a few sets to be taken (see
 * "Spreading the cascade" in docs/allan-engine.md); allan_acc() and
 * allan_flags() take that level's waiting pairs first, so what they return
 * always covers allan_pairs() pairs exactly: hence the non-const engine. */

/* Number of (S_j, S_{j-1}) pairs behind level's accumulator. */
uint32_t allan_pairs(const allan_t *a, uint8_t level);

/* ALLAN_FLAG_* bits for one channel-level; 0 means exact. */
uint8_t allan_flags(allan_t *a, uint8_t ch, uint8_t level);

/* The accumulator of one channel-level, as hi (bits 32..47) and lo. */
void allan_acc(allan_t *a, uint8_t ch, uint8_t level, uint16_t *hi, uint32_t *lo);

/* Take one level's waiting pairs now, or every level's.  allan_acc() does
 * the first itself; a caller with a deep stack at its reads (the report)
 * calls it beforehand from a shallow one. */
void allan_settle_level(allan_t *a, uint8_t level);
void allan_settle(allan_t *a);

/* One piece of that work (the lagging channels, or the lowest waiting
 * level): 1 if there was one, 0 once nothing waits.  For a caller that
 * must give the sampling loop the CPU between pieces (the report). */
uint8_t allan_settle_some(allan_t *a);

/* 1 while some of that work waits (allan_settle_some would do a piece). */
static inline uint8_t allan_waiting(const allan_t *a)
{
  return (a->depth & ALLAN_LAGGING) || a->pend;
}

#endif /* ALLAN_H */
