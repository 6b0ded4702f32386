/*
 * fuzz_fmt - the 3-significant-digit formatting of Allan deviations and
 * taus (firmware/fmt.c) against double precision.
 *
 * Input: acc_hi (16 bits), acc_lo (32), pairs (32), level, rate index,
 * sig3 mantissa (32) and exponent.  Checked, with no UB:
 *   - fmt_adev + fmt_sig3 for any 48-bit accumulator, any pairs and level
 *     0..22: the string is NUL-terminated, its length is what fmt_sig3
 *     returned and below FMT_SIG3_MAX (written into a heap block of exactly
 *     FMT_SIG3_MAX bytes), "0" when acc or pairs is 0, else it satisfies
 *     the acceptance rule of tests/firmware/unit/test_protocol.c (assert_sig3):
 *     3 significant digits (r and zeros from 1000 up), `e-` notation below
 *     0.001 (either notation for values that round up to 0.00100), and |printed - true| <= half a unit of the 3rd
 *     significant digit (x 1.000001) + 1e-4 * true;
 *   - fmt_tau + fmt_sig3 for level 0..22 and each of the six rates, same rule;
 *   - fmt_sig3 alone for mant * 2^exp anywhere between 2^-40 and 2^24 (the
 *     span fmt_adev and fmt_tau produce), same rule.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmt.h"
#include "fuzz_util.h"

static void check_sig3(const char *s, double value, const char *what)
{
  double p, e10, half;
  int digits = 0, leading = 1;
  const char *c;

  for (c = s; *c; c++)
    FUZZ_CHECK((*c >= '0' && *c <= '9') || *c == '.' || *c == 'e' || *c == '-', "%s: '%s' for %.9g", what, s,
               value);
  if (value == 0.0) {
    FUZZ_CHECK(strcmp(s, "0") == 0, "%s: '%s' for 0", what, s);
    return;
  }
  p = strtod(s, NULL);
  e10 = floor(log10(value));
  half = 0.5 * pow(10.0, e10 - 2);
  for (c = s; *c && *c != 'e'; c++) {
    if (*c >= '1' && *c <= '9')
      leading = 0;
    if (*c >= '0' && *c <= '9' && !leading)
      digits++;
  }
  if (p >= 1000.0) /* r and zeros */
    FUZZ_CHECK(digits >= 3 && strchr(s, '.') == NULL, "%s: '%s' for %.9g: not r and zeros", what, s, value);
  else
    FUZZ_CHECK(digits == 3, "%s: '%s' for %.9g: %d significant digits", what, s, value, digits);
  /* e- notation below 0.001.  The unit test's rule decides on the true
   * value; a value in [0.0009995, 0.001) rounds to 3 digits as 0.00100 and
   * fmt_sig3 rightly prints it so, hence the band where either is fine (the
   * band is widened by fmt_adev's 1e-4 relative error). */
  if (value >= 0.001 || value < 0.0009995 * (1.0 - 1e-4))
    FUZZ_CHECK((value < 0.001) == (strstr(s, "e-") != NULL), "%s: '%s' for %.9g: e- notation iff below 0.001",
               what, s, value);
  FUZZ_CHECK(fabs(p - value) <= half * 1.000001 + 1e-4 * value, "%s: '%s' for %.9g: off by %.3g", what, s,
             value, fabs(p - value));
}

/* fmt_sig3 into exactly FMT_SIG3_MAX bytes; returns the block (free it). */
static char *sig3(uint32_t mant, int8_t exp, const char *what)
{
  char *buf = malloc(FMT_SIG3_MAX);
  uint8_t n;
  memset(buf, 0x55, FMT_SIG3_MAX);
  n = fmt_sig3(buf, mant, exp);
  FUZZ_CHECK(n < FMT_SIG3_MAX && buf[n] == 0 && strlen(buf) == n, "%s: fmt_sig3(%u, %d) returned %u", what,
             mant, exp, n);
  return buf;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  static const uint16_t rates[8] = {50, 100, 200, 250, 500, 1000, 1250, 1500};
  fuzz_in_t in = {data, size};
  uint16_t acc_hi = fz_u16(&in);
  uint32_t acc_lo = fz_u32(&in);
  uint32_t pairs = fz_u32(&in);
  uint8_t level = fz_u8(&in) % 23u;
  uint8_t rate = fz_u8(&in) % 8u;
  uint32_t m = fz_u32(&in);
  int8_t e = (int8_t)fz_u8(&in);
  uint32_t mant;
  int8_t exp;
  char *s, what[96];

  /* Allan deviation: sqrt(acc / (2 pairs)) / 2^level. */
  {
    uint64_t acc = (uint64_t)acc_hi << 32 | acc_lo;
    double value = (acc && pairs) ? sqrt((double)acc / (2.0 * pairs)) / ldexp(1.0, level) : 0.0;
    exp = fmt_adev(&mant, acc_hi, acc_lo, pairs, level);
    snprintf(what, sizeof what, "adev(acc=%llu, pairs=%u, level=%u)", (unsigned long long)acc, pairs, level);
    s = sig3(mant, exp, what);
    check_sig3(s, value, what);
    free(s);
  }

  /* tau = 2^level / fs. */
  exp = fmt_tau(&mant, level, rates[rate]);
  snprintf(what, sizeof what, "tau(level=%u, fs=%u)", level, rates[rate]);
  s = sig3(mant, exp, what);
  check_sig3(s, ldexp(1.0, level) / rates[rate], what);
  free(s);

  /* fmt_sig3 alone, within 2^-40 .. 2^24. */
  if (m) {
    int top = 31;
    while (!(m >> top))
      top--;
    /* value in [2^(top+e), 2^(top+e+1)): bring top+e into -40..23 */
    e = (int8_t)(((e + top) % 64 + 64) % 64 - 40 - top);
    snprintf(what, sizeof what, "sig3(%u, %d)", m, e);
    s = sig3(m, e, what);
    check_sig3(s, ldexp((double)m, e), what);
    free(s);
  }
  return 0;
}
