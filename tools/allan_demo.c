/*
 * allan_demo.c - `make demo` before the simulated device existed: the very
 * engine the firmware links (firmware/allan.c), built natively, fed a
 * synthetic thesis-like IMU, printing the Allan table a user would read.
 *
 * Usage: allan-demo [samples] [fs_hz] [seed]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "allan.h"

static uint64_t rng = 0x853c49e6748fea9bull;
static double uniform(void)
{
  rng ^= rng >> 12;
  rng ^= rng << 25;
  rng ^= rng >> 27;
  return ((rng * 2685821657736338717ull) >> 11) * (1.0 / 9007199254740992.0);
}
static double gauss(void)
{
  double u1 = uniform() + 1e-300, u2 = uniform();
  return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

int main(int argc, char **argv)
{
  static allan_t eng;
  static const char *name[ALLAN_CHANNELS] = {"ax", "ay", "az", "gx", "gy", "gz"};
  /* Offsets like the thesis' raw rows; white noise, Gauss-Markov bias and
   * rate random walk in counts, of the order the thesis measured. */
  static const double offset[ALLAN_CHANNELS] = {498, 494, 791, 520, 497, 498};
  static const double white[ALLAN_CHANNELS] = {2.0, 2.5, 1.7, 0.85, 0.6, 0.5};
  static const double gm_sd[ALLAN_CHANNELS] = {0.2, 0.3, 0.05, 0.17, 0.06, 0.05};
  static const double rrw[ALLAN_CHANNELS] = {0.0008, 0.0016, 0.0002, 0, 0, 0};
  double bias[ALLAN_CHANNELS] = {0}, walk[ALLAN_CHANNELS] = {0};
  uint32_t n = argc > 1 ? (uint32_t)strtoul(argv[1], NULL, 0) : 1u << 20;
  double fs = argc > 2 ? atof(argv[2]) : 100.0, tc = 10.0, a = exp(-1.0 / (tc * fs));
  int ch, k;
  uint32_t i;

  if (argc > 3)
    rng += strtoull(argv[3], NULL, 0) * 0x9E3779B97F4A7C15ull;
  if (n < 2 || fs <= 0) {
    fprintf(stderr, "usage: allan-demo [samples>=2] [fs_hz>0] [seed]\n");
    return 2;
  }
  allan_reset(&eng);
  for (i = 0; i < n; i++) {
    uint16_t code[ALLAN_CHANNELS];
    for (ch = 0; ch < ALLAN_CHANNELS; ch++) {
      long c;
      bias[ch] = a * bias[ch] + sqrt(1 - a * a) * gm_sd[ch] * gauss();
      walk[ch] += rrw[ch] * gauss();
      c = lround(offset[ch] + white[ch] * gauss() + bias[ch] + walk[ch]);
      code[ch] = (uint16_t)(c < 0 ? 0 : c > (long)ALLAN_CODE_MAX ? ALLAN_CODE_MAX : c);
    }
    allan_push(&eng, code);
  }

  printf("imu-allan demo: the on-device Allan engine (firmware/allan.c, %d octaves, 6 channels)\n"
         "run natively on a synthetic thesis-like IMU: %u samples at %g Hz (%.2f h)\n\n",
         ALLAN_LEVELS, (unsigned)n, fs, n / fs / 3600.0);
  printf("Allan deviation in ADC counts (non-overlapping, m = 2^level; * = flagged)\n");
  printf("%5s %7s %9s %8s", "level", "m", "tau_s", "pairs");
  for (ch = 0; ch < ALLAN_CHANNELS; ch++)
    printf(" %9s", name[ch]);
  printf("\n");
  for (k = 0; k < ALLAN_LEVELS; k++) {
    uint32_t pairs = allan_pairs(&eng, (uint8_t)k), m = 1u << k;
    if (!pairs)
      break;
    printf("%5d %7u %9.2f %8u", k, (unsigned)m, m / fs, (unsigned)pairs);
    for (ch = 0; ch < ALLAN_CHANNELS; ch++) {
      uint16_t hi;
      uint32_t lo;
      allan_acc(&eng, (uint8_t)ch, (uint8_t)k, &hi, &lo);
      double acc = ldexp((double)hi, 32) + lo;
      printf(" %8.4g%c", sqrt(acc / (2.0 * m * m * pairs)),
             allan_flags(&eng, (uint8_t)ch, (uint8_t)k) ? '*' : ' ');
    }
    printf("\n");
  }
  printf("\nengine state: %u bytes (%u per channel-level)\n", (unsigned)sizeof eng,
         (unsigned)sizeof(allan_cell_t));
  return 0;
}
