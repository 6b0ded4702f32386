/*
 * fmt.h - number formatting for the serial link without printf or floats:
 * decimal, fixed-width hex, and 3 significant digits of Allan deviations
 * and taus computed with 32-bit integers (a tiny binary floating point).
 */
#ifndef FMT_H
#define FMT_H

#include <stdint.h>

/* Longest string fmt_sig3 and friends write, NUL included ("1.23e-12"). */
#define FMT_SIG3_MAX 10

/* Decimal digits of v (no NUL); returns the count, 1..10. */
uint8_t fmt_u32(char *buf, uint32_t v);

/* v as `digits` uppercase hex digits (no NUL). */
void fmt_hex(char *buf, uint32_t v, uint8_t digits);

/* mant * 2^exp to 3 significant digits, NUL-terminated: "164", "2.02",
 * "0.0949", "0.00123", "1.23e-4" (below 0.001), "83900" (3 digits, then
 * zeros).  Returns the length.  32-bit arithmetic only. */
uint8_t fmt_sig3(char *buf, uint32_t mant, int8_t exp);

/* Allan deviation sqrt(acc / (2 pairs)) / 2^level, acc = hi 2^32 + lo,
 * as mant * 2^exp (returned) for fmt_sig3; relative error below 1e-4.
 * Kept apart from the printing so the two never stack on each other. */
int8_t fmt_adev(uint32_t *mant, uint16_t acc_hi, uint32_t acc_lo, uint32_t pairs, uint8_t level);

/* tau = 2^level / fs seconds, as mant * 2^exp (returned). fs > 0. */
int8_t fmt_tau(uint32_t *mant, uint8_t level, uint16_t fs);

/* The mean sum / n of 10-bit codes (sum = hi * 2^32 + lo, below 1024 n:
 * 40 bits hold an hour at 1500 Hz of codes up to 1023, 5.5e9) to one
 * decimal, rounded half up, as whole part + tenth * 2^16 (both come
 * back in registers of their own).  Exact for any n
 * below 2^28 (49 hours at 1500 Hz; the longest report interval, an hour,
 * is 5.4e6 sets), without 64-bit arithmetic. */
uint32_t fmt_mean(uint32_t n, uint32_t lo, uint8_t hi);

#endif /* FMT_H */
