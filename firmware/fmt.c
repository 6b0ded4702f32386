/*
 * fmt.c - see fmt.h.  Runs only while a report is written, never per
 * sample.  Values are carried as mant * 2^exp with a 32-bit mantissa kept
 * normalised (top bit set), which is plenty for 3 significant digits and
 * needs neither 64-bit arithmetic nor the float library.
 */
#include "fmt.h"

#include "pgm.h"

uint8_t fmt_u32(char *buf, uint32_t v)
{
  /* Digits from the top by repeated subtraction: no division, no buffer. */
  static const uint32_t pow10[9] PROGMEM = {1000000000ul, 100000000ul, 10000000ul, 1000000ul, 100000ul,
                                            10000ul,      1000ul,      100ul,      10ul};
  uint8_t n = 0, i;
  for (i = 0; i < 9; i++) {
    uint32_t p = pgm_read_dword(&pow10[i]);
    char d = '0';
    while (v >= p) {
      v -= p;
      d++;
    }
    if (n || d != '0')
      buf[n++] = d;
  }
  buf[n++] = (char)('0' + v);
  return n;
}

void fmt_hex(char *buf, uint32_t v, uint8_t digits)
{
  while (digits--) {
    uint8_t d = (uint8_t)(v & 0xFu);
    buf[digits] = (char)(d < 10 ? '0' + d : 'A' + d - 10);
    v >>= 4;
  }
}

static void normalize(uint32_t *m, int8_t *e)
{
  while (!(*m & 0x80000000ul)) {
    *m <<= 1;
    (*e)--;
  }
}

uint8_t fmt_sig3(char *buf, uint32_t m, int8_t e)
{
  int8_t j = 0; /* value * 10^j = m * 2^e */
  int8_t p, pos, bottom;
  uint16_t r;
  char *o = buf;
  const char *d = buf + FMT_SIG3_MAX - 3; /* the 3 digits, at the buffer's end: read before written over */

  if (!m) {
    buf[0] = '0';
    buf[1] = 0;
    return 1;
  }
  normalize(&m, &e);
  for (;;) {
    /* With m in [2^31, 2^32), value in [2^(31+e), 2^(32+e)). */
    uint8_t s = (uint8_t)-e;
    r = e >= -21 ? 1000u : e < -25 ? 0u : (uint16_t)(m >> s);
    if (r >= 1000u) { /* divide by 10 */
      m /= 10u;
      j--;
    } else if (r < 100u) { /* multiply by 10 = by 0.625 * 16 */
      m = (m >> 1) + (m >> 3);
      e = (int8_t)(e + 4);
      j++;
    } else {
      /* Decide the decade on the truncated value, then round: 99.96 must
       * become 100 (three digits), never "100." at the wrong decade. */
      r = (uint16_t)(((m >> (s - 1)) + 1u) >> 1);
      if (r == 1000u) { /* 999.5 and up: 100 at the next decade */
        r = 100u;
        j--;
      }
      break;
    }
    normalize(&m, &e);
  }
  fmt_u32(buf + FMT_SIG3_MAX - 3, r);
  /* The digits are 10^p, 10^(p-1), 10^(p-2): written from 10^max(p, 0)
   * down to 10^min(p-2, 0), the point before 10^-1, zeros outside them;
   * below 0.001, as d.dd then e-<exponent>. */
  p = (int8_t)(2 - j);
  if (p < -3)
    p = 0;
  bottom = p < 2 ? (int8_t)(p - 2) : 0;
  for (pos = p > 0 ? p : 0; pos >= bottom; pos--) {
    uint8_t k = (uint8_t)(p - pos);
    if (pos == -1)
      *o++ = '.';
    *o++ = k <= 2 ? d[k] : '0';
  }
  if (j > 5) {
    *o++ = 'e';
    *o++ = '-';
    o += fmt_u32(o, (uint8_t)(j - 2));
  }
  *o = 0;
  return (uint8_t)(o - buf);
}

static uint16_t isqrt32(uint32_t x)
{
  uint32_t r = 0, b = 1ul << 30;
  while (b > x)
    b >>= 2;
  while (b) {
    if (x >= r + b) {
      x -= r + b;
      r = (r >> 1) + b;
    } else {
      r >>= 1;
    }
    b >>= 2;
  }
  return (uint16_t)r;
}

int8_t fmt_adev(uint32_t *mant, uint16_t acc_hi, uint32_t acc_lo, uint32_t pairs, uint8_t level)
{
  uint32_t a = acc_lo, p = pairs, q;
  int8_t e = 0; /* avar * m^2 = q * 2^e */

  if ((!acc_hi && !acc_lo) || !pairs) {
    *mant = 0;
    return 0;
  }
  /* a: the accumulator's top 32 bits; p: pairs' top 16 bits. */
  if (acc_hi) {
    while (acc_hi) {
      a >>= 1;
      if (acc_hi & 1u)
        a |= 0x80000000ul;
      acc_hi >>= 1;
      e++;
    }
  } else {
    normalize(&a, &e);
  }
  while (p >> 16) {
    p >>= 1;
    e--;
  }
  while (!(p & 0x8000u)) {
    p <<= 1;
    e++;
  }
  q = a / p; /* in (2^15, 2^17]: 16 significant bits */
  e--;       /* the 2 of 2 * pairs */
  /* sqrt needs an even exponent and a mantissa near 2^30. */
  if (e & 1) {
    q <<= 1;
    e--;
  }
  while (q < (1ul << 28)) {
    q <<= 2;
    e = (int8_t)(e - 2);
  }
  *mant = isqrt32(q);
  return (int8_t)(e / 2 - (int8_t)level);
}

uint32_t fmt_mean(uint32_t n, uint32_t lo, uint8_t hi)
{
  uint32_t r = 0;
  uint8_t i = 40;
  /* Long division, a bit at a time: hi:lo shifts into r (r < n, so r * 2
   * + 1 needs 33 bits: the carry) and takes the quotient's bits in at its
   * bottom; after 40 steps lo holds the quotient (below 2^10). */
#ifdef __AVR__
  __asm__("1: lsl %A[lo]\n\trol %B[lo]\n\trol %C[lo]\n\trol %D[lo]\n\trol %[hi]\n\t"
          "rol %A[r]\n\trol %B[r]\n\trol %C[r]\n\trol %D[r]\n\t"
          "brcs 2f\n\t"
          "cp %A[r], %A[n]\n\tcpc %B[r], %B[n]\n\tcpc %C[r], %C[n]\n\tcpc %D[r], %D[n]\n\t"
          "brcs 3f\n"
          "2: sub %A[r], %A[n]\n\tsbc %B[r], %B[n]\n\tsbc %C[r], %C[n]\n\tsbc %D[r], %D[n]\n\t"
          "inc %A[lo]\n"
          "3: dec %[i]\n\tbrne 1b"
          : [lo] "+r"(lo), [hi] "+r"(hi), [r] "+r"(r), [i] "+r"(i)
          : [n] "r"(n));
#else
  for (; i; i--) {
    uint8_t carry = (uint8_t)(r >> 31);
    r = (r << 1) | (uint8_t)(hi >> 7);
    hi = (uint8_t)((hi << 1) | (uint8_t)(lo >> 31));
    lo <<= 1;
    if (carry || r >= n) {
      r -= n;
      lo++;
    }
  }
#endif
  r = (r * 10u + (n >> 1)) / n; /* the tenth, rounded half up (r < n < 2^28) */
  if (r == 10u) {               /* x.95 and up */
    lo++;
    r = 0;
  }
  return (uint16_t)lo | r << 16;
}

int8_t fmt_tau(uint32_t *mant, uint8_t level, uint16_t fs)
{
  *mant = 0x80000000ul / fs;
  return (int8_t)(level - 31);
}
