/*
 * units.h - the thesis board's scale factors (docs/protocol.md, Summary):
 * from ADC counts to the units the summary prints, per quantity and kind
 * of channel.  Pure: builds on the AVR (table in flash) and natively.
 *
 * The board's facts, one home on the device (host_scripts/imu_allan/
 * profiles.py holds the host's; host_scripts/tests/test_units_table.py checks
 * that the two agree): a 10-bit ADC on a 3.3 V reference; MMA7260Q
 * accelerometer 800/600/300/200 mV/g at 1.5/2/4/6 g; LISY300AL gyroscope
 * 3.3 mV/(deg/s).  One count is then 3300/1024/800 g = 4.0283 mg at
 * 1.5 g, and 3300/1024/3.3 = 0.97656 deg/s.
 */
#ifndef UNITS_H
#define UNITS_H

#include <stdint.h>

#define UNITS_VREF_MV 3300.0
#define UNITS_ADC_STEPS 1024.0
/* MMA7260Q sensitivity at the ranges RANGE_1G5, RANGE_2G, RANGE_4G, RANGE_6G */
#define UNITS_ACC_MV_PER_G_1G5 800.0
#define UNITS_ACC_MV_PER_G_2G 600.0
#define UNITS_ACC_MV_PER_G_4G 300.0
#define UNITS_ACC_MV_PER_G_6G 200.0
#define UNITS_GYRO_MV_PER_DPS 3.3
#define UNITS_G0 9.80665    /* m/s^2 per g */
#define UNITS_B_FLOOR 0.664 /* Allan deviation of flicker noise / B (IEEE 952) */

/* Quantities: the Allan deviation (mg, deg/s), N = sigma sqrt(tau) (VRW
 * m/s/sqrt(h), ARW deg/sqrt(h)) and B = sigma / 0.664 (mg, deg/h); in
 * counts mode count, count sqrt(s) and count. */
enum { UNITS_ADEV, UNITS_N, UNITS_B, UNITS_QUANTITIES };

/* Kinds of channel: counts (any channel in `units counts`), an
 * accelerometer at RANGE_* (UNITS_ACC + range), a gyroscope. */
#define UNITS_COUNTS 0
#define UNITS_ACC 1
#define UNITS_GYRO 5
#define UNITS_KINDS 6

/* A factor f = k * 2^e, k in [2^15, 2^16) (1 * 2^0 for counts unscaled). */
typedef struct {
  uint16_t k;
  int8_t e;
} units_factor_t;

extern const units_factor_t units_factors[UNITS_QUANTITIES][UNITS_KINDS];

/* mant * 2^exp in counts (mant below 2^16) times the factor of quantity q
 * for a channel of this kind: the new mant, exact (32 bits), and the new
 * exponent (returned). */
int8_t units_scale(uint32_t *mant, int8_t exp, uint8_t q, uint8_t kind);

#endif /* UNITS_H */
