/*
 * units.c - see units.h.  The factors are worked out by the compiler from
 * the board's facts (constant expressions: no float library on the AVR).
 */
#include "units.h"

#include "pgm.h"

/* floor(log2 f) for the factors here, 1/2 <= f < 2^14. */
#define LOG2(f)                                                                                              \
  ((f) >= 8192 ? 13 :                                                                                        \
   (f) >= 4096 ? 12 :                                                                                        \
   (f) >= 2048 ? 11 :                                                                                        \
   (f) >= 1024 ? 10 :                                                                                        \
   (f) >= 512  ? 9 :                                                                                         \
   (f) >= 256  ? 8 :                                                                                         \
   (f) >= 128  ? 7 :                                                                                         \
   (f) >= 64   ? 6 :                                                                                         \
   (f) >= 32   ? 5 :                                                                                         \
   (f) >= 16   ? 4 :                                                                                         \
   (f) >= 8    ? 3 :                                                                                         \
   (f) >= 4    ? 2 :                                                                                         \
   (f) >= 2    ? 1 :                                                                                         \
   (f) >= 1    ? 0 :                                                                                         \
                 -1)
#define FACTOR(f)                                                                                            \
  {                                                                                                          \
    (uint16_t)((f) * (double)(1l << (15 - LOG2(f))) + 0.5), (int8_t)(LOG2(f) - 15)                           \
  }

#define VOLT_MV (UNITS_VREF_MV / UNITS_ADC_STEPS)      /* mV per count */
#define ACC_MG(mv_per_g) (VOLT_MV / (mv_per_g)*1000.0) /* mg per count */
#define GYRO_DPS (VOLT_MV / UNITS_GYRO_MV_PER_DPS)     /* deg/s per count */
/* sqrt(s) -> sqrt(h): 60; mg sqrt(s) -> m/s/sqrt(h): 60 g0 / 1000 */
#define ADEV_ACC(s) ACC_MG(s)
#define N_ACC(s) (ACC_MG(s) * 60.0 * UNITS_G0 / 1000.0)
#define B_ACC(s) (ACC_MG(s) / UNITS_B_FLOOR)

/* Counts stay as they are: factor 1 as 1 * 2^0 (report.c's search of B
 * relies on the deviation in counts coming out unscaled). */
#define PER_KIND(acc, gyro)                                                                                  \
  {                                                                                                          \
    {1, 0}, FACTOR(acc(UNITS_ACC_MV_PER_G_1G5)), FACTOR(acc(UNITS_ACC_MV_PER_G_2G)),                         \
        FACTOR(acc(UNITS_ACC_MV_PER_G_4G)), FACTOR(acc(UNITS_ACC_MV_PER_G_6G)), FACTOR(gyro)                 \
  }

const units_factor_t units_factors[UNITS_QUANTITIES][UNITS_KINDS] PROGMEM = {
    PER_KIND(ADEV_ACC, GYRO_DPS),
    PER_KIND(N_ACC, GYRO_DPS * 60.0),
    {FACTOR(1.0 / UNITS_B_FLOOR), FACTOR(B_ACC(UNITS_ACC_MV_PER_G_1G5)), FACTOR(B_ACC(UNITS_ACC_MV_PER_G_2G)),
     FACTOR(B_ACC(UNITS_ACC_MV_PER_G_4G)), FACTOR(B_ACC(UNITS_ACC_MV_PER_G_6G)),
     FACTOR(GYRO_DPS * 3600.0 / UNITS_B_FLOOR)},
};

int8_t units_scale(uint32_t *mant, int8_t exp, uint8_t q, uint8_t kind)
{
  const units_factor_t *f = &units_factors[q][kind];
  *mant *= pgm_read_word(&f->k);
  return (int8_t)(exp + (int8_t)pgm_read_byte(&f->e));
}
