/*
 * allan.c - the on-device Allan engine (see allan.h for the contract).
 *
 * Cascade: a level-k cluster is two consecutive level-(k-1) clusters, so
 * when level k-1 completes an even-numbered cluster, level k's new sum is
 * (level k-1's previous sum) + (its new sum).  The previous sum is exactly
 * what level k-1 stores for its own difference, so each channel-level needs
 * nothing beyond its last sum and its accumulator.
 */
#include "allan.h"

#include <string.h>

#define SUM_MASK 0x00FFFFFFul
#define SUM_SIGN 0x00800000ul

/* Cluster sums are 24-bit quantities: avr-gcc has a native 24-bit type,
 * which saves registers in the cascade; the host uses 32 bits and masks. */
#ifdef __AVR__
typedef __uint24 allan_sum_t;
#else
typedef uint32_t allan_sum_t;
#endif

#if ALLAN_CODE_MAX > 1023u
#  error "lagging channels park 11 bits in the spare bits of levels 0 and 1 (10-bit codes)"
#endif
#if ALLAN_LAG_DEPTH < 3
#  error "ALLAN_LAG_DEPTH must be at least 3: lagging channels defer levels 2 and up"
#endif
#if ALLAN_CODE_MAX * (1ul << (ALLAN_WIDE_LEVEL - 1)) >= (1ul << ALLAN_SUM_BITS)
#  error "ALLAN_WIDE_LEVEL is wrong for ALLAN_CODE_MAX: level WIDE-1 sums must fit 24 bits"
#endif
#if ALLAN_CODE_MAX * (1ul << (ALLAN_NARROW_LEVELS - 1)) >= (1ul << 16)
#  error "ALLAN_NARROW_LEVELS is wrong for ALLAN_CODE_MAX: its sums must fit 16 bits"
#endif

/* ext: the accumulator's bits 40..47, or 0 for a 40-bit level.  Inline:
 * cell_add_wide, on the deepest stack of the sampling path, calls nothing. */
static inline __attribute__((always_inline)) void cell_saturate(allan_cell_t *c, uint8_t *ext)
{
  c->acc_lo = 0xFFFFFFFFul;
  c->acc_mid = 0xFF;
  if (ext)
    *ext = 0xFF;
}

static uint8_t *acc_ext(allan_t *a, uint8_t ch, uint8_t level);

/* A carry out of bit 31 ripples into bits 32..39, then 40..47 where the
 * level has them; past its width the accumulator saturates.  Out of line:
 * it runs once per 2^32 of accumulated squares at most. */
static __attribute__((noinline)) void cell_carry(allan_t *a, uint8_t ch, uint8_t level)
{
  allan_cell_t *c = &a->cell[ch][level];
  uint8_t *ext;
  if (++c->acc_mid)
    return;
  ext = acc_ext(a, ch, level);
  if (ext && *ext != 0xFF)
    (*ext)++;
  else
    cell_saturate(c, ext);
}

/* acc += d^2 for d >= 2^16 (d < 2^24): d = a 2^16 + b, so
 * d^2 = a^2 2^32 + 2ab 2^16 + b^2, added in 32-bit pieces.  Rare: only
 * high levels see differences this large.  Calls nothing, to keep the
 * deepest stack of the sampling path short. */
static __attribute__((noinline)) void cell_add_wide(allan_cell_t *c, uint8_t *ext, uint32_t d)
{
  /* Few values live at once, so that this rare path needs a small frame
   * on the deepest stack of the sampling path. */
  uint16_t a = (uint16_t)(d >> 16), b = (uint16_t)d, up;
  uint32_t t, lo;
  __asm__("" : "+r"(a), "+r"(b)); /* 16 x 16 multiplies, not 32 x 32 */
  t = (uint32_t)b * b;            /* b^2 */
  lo = c->acc_lo + t;
  up = (uint16_t)(lo < t) + a * a; /* bits 32.. of acc + a^2 2^32 + b^2: below 2^16 */
  t = (uint32_t)a * b * 2u;        /* 2ab, below 2^25, goes in at bit 16 */
  up += (uint16_t)(t >> 16);       /* still below 2^16: a^2 + 2^9 + 2 */
  t <<= 16;
  lo += t;
  up += lo < t;
  /* Bits 32.. of the sum are up + acc_mid (below 2^17): the low byte is
   * the new acc_mid, the rest must fit the extension byte (48-bit levels
   * only). */
  {
    uint16_t sum = up + c->acc_mid;
    uint16_t top = (uint16_t)((sum >> 8) | (sum < up ? 0x100u : 0u));
    if (top) {
      if (!ext || (uint16_t)(*ext + top) > 0xFFu) {
        cell_saturate(c, ext);
        return;
      }
      *ext = (uint8_t)(*ext + top);
    }
    c->acc_lo = lo;
    c->acc_mid = (uint8_t)sum;
  }
}

/* acc += d^2 for d < 2^16, the common case (every level-0 pair and nearly
 * all others): one 16x16 multiply and a 32-bit add. */
static inline __attribute__((always_inline)) void cell_add_small(allan_t *a, uint8_t ch, uint8_t level,
                                                                 allan_cell_t *c, uint16_t d)
{
  uint32_t sq, lo;
  /* Hide d's origin so that avr-gcc multiplies 16 x 16 (not 32 x 32). */
  __asm__("" : "+r"(d));
  sq = (uint32_t)d * d;
  lo = c->acc_lo + sq;
  c->acc_lo = lo;
  if (lo < sq)
    cell_carry(a, ch, level);
}

/* acc += d^2, saturating at the accumulator's width. */
static inline __attribute__((always_inline)) void cell_add_square(allan_t *a, uint8_t ch, uint8_t level,
                                                                  allan_cell_t *c, uint32_t d)
{
  if (d < 0x10000ul)
    cell_add_small(a, ch, level, c, (uint16_t)d);
  else
    cell_add_wide(c, acc_ext(a, ch, level), d);
}

static uint8_t *acc_ext(allan_t *a, uint8_t ch, uint8_t level)
{
  return ALLAN_IS_ACC48(level) ? &a->acc_hi[ch][level - ALLAN_ACC48_FROM] : 0;
}

#if ALLAN_LEVELS > ALLAN_WIDE_LEVEL
/* The 2^23 difference bound for a wide level, from the channel's code range. */
static uint8_t range_breaks(const allan_t *a, uint8_t ch, uint8_t level)
{
  if (level < ALLAN_WIDE_LEVEL || a->max[ch] < a->min[ch])
    return 0;
  return (uint16_t)(a->max[ch] - a->min[ch]) >= (1ul << (ALLAN_SUM_BITS - 1 - level));
}
#endif

void allan_reset(allan_t *a)
{
  memset(a, 0, sizeof *a);
#if ALLAN_LEVELS > ALLAN_WIDE_LEVEL
  {
    uint8_t ch;
    for (ch = 0; ch < ALLAN_CHANNELS; ch++)
      a->min[ch] = ALLAN_CODE_MAX;
  }
#endif
}

/* One narrow level k (sums below 2^16): pair the new cluster sum v with the
 * previous one, store it, and return the next level's new sum (24 bits: it
 * leaves 16 after the last narrow level). */
static inline __attribute__((always_inline)) allan_sum_t narrow_step(allan_t *a, uint8_t ch, uint8_t k,
                                                                     allan_cell_t *c, uint16_t v)
{
  uint16_t last = c->sum_lo;
  if (a->depth != (uint8_t)(ALLAN_TOP_FIRST | (k + 1u))) /* not level k's first cluster */
    cell_add_small(a, ch, k, c, v >= last ? v - last : last - v);
  c->sum_lo = v;
  return (allan_sum_t)v + last;
}

/* |v - last| for the two latest cluster sums of level k. */
static inline __attribute__((always_inline)) uint32_t pair_diff(uint8_t k, allan_sum_t v, allan_sum_t last)
{
  uint32_t d;
#if ALLAN_LEVELS > ALLAN_WIDE_LEVEL
  if (k >= ALLAN_WIDE_LEVEL) {
    /* Sums mod 2^24; |dS| < 2^23 was proven by the code range when the
     * pair completed (a broken bound saturated the level then), so
     * sign-extend. */
    d = (uint32_t)(v - last) & SUM_MASK;
    if (d & SUM_SIGN)
      d = (SUM_MASK + 1ul) - d;
    return d;
  }
#else
  (void)k;
#endif
  /* True sums below 2^24: plain subtraction is exact. */
  d = v >= last ? (uint32_t)(v - last) : (uint32_t)(last - v);
  return d;
}

/* Level k's deferred pairs, for every channel (returns ALLAN_OK, for
 * allan_begin's tail call).  Level k+1 completed with
 * each, so level k's previous sum is level k+1's sum minus level k's: both
 * stay in place until level k completes again, 2^k sets later. */
static __attribute__((noinline)) uint8_t settle(allan_t *a, uint8_t k)
{
  allan_cell_t *c = &a->cell[0][k];
  uint8_t ch;
  for (ch = 0; ch < ALLAN_CHANNELS; ch++, c += ALLAN_LEVELS) {
    allan_sum_t v = c->sum_lo, up = c[1].sum_lo;
    if (k + 1u >= ALLAN_NARROW_LEVELS) {
      const uint8_t *hi = &a->sum_hi[ch][k + 1u - ALLAN_NARROW_LEVELS]; /* level k+1's top byte */
      up |= (allan_sum_t)hi[0] << 16;
      if (k >= ALLAN_NARROW_LEVELS)
        v |= (allan_sum_t)hi[-1] << 16;
    }
    cell_add_square(a, ch, k, c, pair_diff(k, v, (allan_sum_t)((up - v) & SUM_MASK)));
  }
  a->pend &= (allan_pend_t) ~((allan_pend_t)1 << k);
  return ALLAN_OK;
}

/* Lowest level with a deferred pair (pend != 0): a byte, a nibble, then
 * bit tests, as the AVR shifts one bit per instruction and this runs for
 * every channel of a set that takes waiting pairs. */
static uint8_t lowest_pending(allan_pend_t pend)
{
  uint8_t k = 0, b;
  while (!(uint8_t)pend) {
    pend >>= 8;
    k += 8;
  }
  b = (uint8_t)pend;
  if (!(b & 0x0Fu)) {
    b >>= 4;
    k += 4;
  }
  return (uint8_t)(k + ((b & 1u) ? 0u : (b & 2u) ? 1u : (b & 4u) ? 2u : 3u));
}

static void lag_catch_up(allan_t *a);

__attribute__((noinline)) uint8_t allan_begin(allan_t *a)
{
  uint32_t n;
  uint8_t depth, caught_up = 0;

  if (a->n == 0xFFFFFFFFul)
    return ALLAN_ERR_FULL;
  if (a->depth & ALLAN_LAGGING) { /* the last set's lagging channels: this set's first work */
    lag_catch_up(a);
    caught_up = 1;
  }
  n = ++a->n;
  /* Sample n completes a cluster at every level k with 2^k | n: `depth`
   * levels.  Level k has a pair unless this is its very first cluster,
   * i.e. unless n == 2^k, which can only be the top level: ALLAN_TOP_FIRST
   * in `depth` says so.  Both are worked out once here, in 8 bits, for all
   * channels. */
  depth = 1;
  if (!(uint8_t)n) { /* a byte at a time first: the AVR shifts one bit per instruction */
    while (!(uint8_t)n && depth + 8u <= ALLAN_LEVELS) {
      n >>= 8;
      depth += 8;
    }
  }
  while (depth < ALLAN_LEVELS && !(n & 1u)) { /* shift out trailing zeros */
    n >>= 1;
    depth++;
  }
  a->depth = depth;
  /* What is left is 1 exactly when the count was 2^(depth-1): the top
   * level's first cluster, which has no pair yet. */
  if (n == 1u)
    a->depth = (uint8_t)(depth | ALLAN_TOP_FIRST);

  if (depth > 2u) {
    /* Deferred pairs of levels this set overwrites are settled first (a
     * safety net: the schedule below settles them long before, see
     * docs/allan-engine.md).  This set's pairs at levels 2 .. depth-2
     * are deferred; the top level's pair is taken now, its previous sum
     * being nowhere else. */
    allan_pend_t mask = (allan_pend_t)(((allan_pend_t)1 << depth) - 1u);
    while (a->pend & mask)
      settle(a, lowest_pending(a->pend));
    a->pend |= (allan_pend_t)((mask >> 1) & ~(allan_pend_t)3u);
    return ALLAN_OK;
  }
  /* A set that cascades no higher than level 1 (three in four) takes the
   * lowest waiting level's pairs, unless it took lagging channels' work. */
  if (a->pend && !caught_up)
    return settle(a, lowest_pending(a->pend)); /* last, so that its frame replaces this one */
  return ALLAN_OK;
}

/* Levels 2 .. depth-1 of one channel, v16 being the new level-2 cluster
 * sum.  Out of line: three samples in four need none of it, and levels 0
 * and 1 then run with a small frame.  Every level but the top one only
 * stores its new sum and passes the next level's on (its pair waits in
 * `pend`, see settle()); the top level takes its pair here. */
static __attribute__((noinline)) void cascade_up(allan_t *a, uint8_t ch, uint16_t v16)
{
  allan_cell_t *c = &a->cell[ch][2];
  uint8_t k = 2, top = (uint8_t)((a->depth & ALLAN_DEPTH_MASK) - 1u);
  allan_sum_t v, last;
  uint8_t *hi;

  /* Levels below the last narrow one: their sums and the next level's
   * stay below 2^16. */
#if defined(__AVR__)
  {
    /* The same as the loop below, 15 cycles a level (the compiler's: 19);
     * this runs for every level of every channel of the deepest sets. */
    uint8_t n = (uint8_t)((top < ALLAN_NARROW_LEVELS - 1u ? top : ALLAN_NARROW_LEVELS - 1u) - 2u);
    if (n) {
      uint16_t l16;
      k = (uint8_t)(k + n);
      __asm__ volatile("1:\n\t"
                       "ld %A[l], %a[c]\n\t"
                       "ldd %B[l], %a[c]+1\n\t"
                       "st %a[c], %A[v]\n\t"
                       "std %a[c]+1, %B[v]\n\t"
                       "add %A[v], %A[l]\n\t"
                       "adc %B[v], %B[l]\n\t"
                       "adiw %A[c], %[size]\n\t"
                       "dec %[n]\n\t"
                       "brne 1b"
                       : [v] "+r"(v16), [n] "+d"(n), [l] "=&r"(l16), [c] "+b"(c)
                       : [size] "n"(sizeof(allan_cell_t))
                       : "memory");
    }
  }
#else
  for (; k < top && k < ALLAN_NARROW_LEVELS - 1u; k++, c++) {
    uint16_t l16 = c->sum_lo;
    c->sum_lo = v16;
    v16 = (uint16_t)(v16 + l16);
  }
#endif
  v = v16;
  if (k < top && k == ALLAN_NARROW_LEVELS - 1u) { /* the last narrow level: the next sum is wide */
    last = c->sum_lo;
    c->sum_lo = v16;
    v += last;
    k++;
    c++;
  }
  if (k < ALLAN_NARROW_LEVELS) { /* the top level is narrow */
    last = c->sum_lo;
    c->sum_lo = (uint16_t)v;
  } else {
    hi = &a->sum_hi[ch][k - ALLAN_NARROW_LEVELS];
#if defined(__AVR__) && ALLAN_LEVELS <= ALLAN_WIDE_LEVEL
    if (k < top) {
      /* The loop below without its range check (no wide levels here), 20
       * cycles a level (the compiler's: 26). */
      uint8_t n = (uint8_t)(top - k);
      allan_sum_t l;
      k = top;
      __asm__ volatile("1:\n\t"
                       "ld %A[l], %a[c]\n\t"
                       "ldd %B[l], %a[c]+1\n\t"
                       "ld %C[l], %a[h]\n\t"
                       "st %a[c], %A[v]\n\t"
                       "std %a[c]+1, %B[v]\n\t"
                       "st %a[h]+, %C[v]\n\t"
                       "add %A[v], %A[l]\n\t"
                       "adc %B[v], %B[l]\n\t"
                       "adc %C[v], %C[l]\n\t"
                       "adiw %A[c], %[size]\n\t"
                       "dec %[n]\n\t"
                       "brne 1b"
                       : [v] "+r"(v), [n] "+d"(n), [l] "=&r"(l), [c] "+b"(c), [h] "+e"(hi)
                       : [size] "n"(sizeof(allan_cell_t))
                       : "memory");
    }
#else
    for (; k < top; k++, c++, hi++) {
      last = c->sum_lo | ((allan_sum_t)*hi << 16);
#  if ALLAN_LEVELS > ALLAN_WIDE_LEVEL
      if (k >= ALLAN_WIDE_LEVEL && range_breaks(a, ch, k))
        cell_saturate(c, acc_ext(a, ch, k)); /* cannot vouch for this difference */
#  endif
      c->sum_lo = (uint16_t)v;
      *hi = (uint8_t)(v >> 16);
      /* The next level's cluster is this one and the one before it. */
      v = (allan_sum_t)((v + last) & SUM_MASK);
    }
#endif
    last = c->sum_lo | ((allan_sum_t)*hi << 16);
    c->sum_lo = (uint16_t)v;
    *hi = (uint8_t)(v >> 16);
  }
  if (a->depth & ALLAN_TOP_FIRST)
    return; /* the top level's first cluster: no pair yet */
#if ALLAN_LEVELS > ALLAN_WIDE_LEVEL
  if (k >= ALLAN_WIDE_LEVEL && range_breaks(a, ch, k)) {
    cell_saturate(c, acc_ext(a, ch, k)); /* cannot vouch for this difference */
    return;
  }
#endif
  cell_add_square(a, ch, k, c, pair_diff(k, v, last));
}

/* Lagging channels (see "Spreading the cascade" in docs/allan-engine.md):
 * in a set that completes ALLAN_LAG_DEPTH levels or more, channels
 * ALLAN_LAG_FROM and up take levels 0 and 1 as always but leave levels
 * 2 and up (cascade_up) to the start of the next set, or to a read before
 * it.  What cascade_up needs then is the new level-2 sum, i.e. level 1's
 * previous sum (its new one stays in place): 11 bits, parked in bits no
 * sum uses.  Level 0's sum is a code (bits 0..9) and level 1's a sum of
 * two (bits 0..10), so bits 10..15 of the first and 11..15 of the second
 * are free; level 0 is next written by the next set, after the catch-up. */
static void lag_park(allan_cell_t *c, uint16_t prev1)
{
  c[0].sum_lo |= (uint16_t)(prev1 << 10);
  c[1].sum_lo |= (uint16_t)((prev1 << 5) & 0xF800u);
}

/* The lagging channels' levels 2 and up, with the depth of their set. */
static __attribute__((noinline)) void lag_catch_up(allan_t *a)
{
  uint8_t ch;
  a->depth &= (uint8_t)~ALLAN_LAGGING;
  for (ch = ALLAN_LAG_FROM; ch < ALLAN_CHANNELS; ch++) {
    allan_cell_t *c = a->cell[ch];
    uint16_t s0 = c[0].sum_lo, s1 = c[1].sum_lo;
    c[0].sum_lo = s0 & 0x03FFu;
    s0 = (uint16_t)((s0 >> 10) | ((s1 >> 5) & 0x07C0u)); /* level 1's previous sum */
    s1 &= 0x07FFu;                                       /* and its new one */
    c[1].sum_lo = s1;
    cascade_up(a, ch, (uint16_t)(s0 + s1));
  }
}

/* Lagging channels first: every read and every new set sees them done. */
static inline __attribute__((always_inline)) void lag_settle(allan_t *a)
{
  if (a->depth & ALLAN_LAGGING)
    lag_catch_up(a);
}

void allan_channel(allan_t *a, uint8_t ch, uint16_t code)
{
  /* Levels 0 and 1 here (every sample, every other sample), the rest out
   * of line: the cluster at level 0 is the code itself. */
  allan_cell_t *c = a->cell[ch];
  uint16_t v;

#if ALLAN_LEVELS > ALLAN_WIDE_LEVEL
  if (code < a->min[ch])
    a->min[ch] = code;
  if (code > a->max[ch])
    a->max[ch] = code;
#endif
  v = (uint16_t)narrow_step(a, ch, 0, c, code);
  if ((a->depth & ALLAN_DEPTH_MASK) > 1u) {
    v = (uint16_t)narrow_step(a, ch, 1, c + 1, v);
    if ((a->depth & ALLAN_DEPTH_MASK) > 2u) {
      if (ch >= ALLAN_LAG_FROM && (a->depth & ALLAN_DEPTH_MASK) >= ALLAN_LAG_DEPTH) {
        lag_park(c, (uint16_t)(v - c[1].sum_lo));
        a->depth |= ALLAN_LAGGING;
      } else {
        cascade_up(a, ch, v);
      }
    }
  }
}

uint8_t allan_push(allan_t *a, const uint16_t code[ALLAN_CHANNELS])
{
  uint8_t ch, err;
  for (ch = 0; ch < ALLAN_CHANNELS; ch++)
    if (code[ch] > ALLAN_CODE_MAX)
      return ALLAN_ERR_CODE;
  err = allan_begin(a);
  if (err)
    return err;
  for (ch = 0; ch < ALLAN_CHANNELS; ch++)
    allan_channel(a, ch, code[ch]);
  return ALLAN_OK;
}

uint32_t allan_pairs(const allan_t *a, uint8_t level)
{
  uint32_t clusters = a->n >> level;
  return clusters >= 2 ? clusters - 1 : 0;
}

void allan_settle_level(allan_t *a, uint8_t level)
{
  lag_settle(a);
  if ((a->pend >> level) & 1u)
    settle(a, level);
}

void allan_settle(allan_t *a)
{
  while (allan_settle_some(a))
    ;
}

uint8_t allan_settle_some(allan_t *a)
{
  if (a->depth & ALLAN_LAGGING) {
    lag_catch_up(a);
    return 1;
  }
  if (!a->pend)
    return 0;
  settle(a, lowest_pending(a->pend));
  return 1;
}

void allan_acc(allan_t *a, uint8_t ch, uint8_t level, uint16_t *hi, uint32_t *lo)
{
  const allan_cell_t *c = &a->cell[ch][level];
  lag_settle(a);
  if ((a->pend >> level) & 1u)
    settle(a, level); /* this level's waiting pairs, for every channel */
  uint16_t h = c->acc_mid;
  if (ALLAN_IS_ACC48(level))
    h |= (uint16_t)a->acc_hi[ch][level - ALLAN_ACC48_FROM] << 8;
  *hi = h;
  *lo = c->acc_lo;
}

uint8_t allan_flags(allan_t *a, uint8_t ch, uint8_t level)
{
  uint16_t hi;
  uint32_t lo;
  uint8_t f = 0;
  allan_acc(a, ch, level, &hi, &lo);
  if (lo == 0xFFFFFFFFul && hi == (ALLAN_IS_ACC48(level) ? 0xFFFFu : 0xFFu))
    f |= ALLAN_FLAG_SAT;
#if ALLAN_LEVELS > ALLAN_WIDE_LEVEL
  if (a->n && range_breaks(a, ch, level))
    f |= ALLAN_FLAG_RANGE;
#endif
  return f;
}
