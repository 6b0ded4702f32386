/*
 * sim_measure.h - what imu-sim measures (cycles, stack) and --stats.
 */
#ifndef SIM_MEASURE_H
#define SIM_MEASURE_H

#include <stdint.h>

#include "harness.h"

void measure_connect(harness_t *h); /* hooks PB0..PB2 and the sleep callback */
int elf_is_avr(const char *path);
uint16_t elf_bss_end(const char *path);
void print_stats(harness_t *h, int json);

#endif /* SIM_MEASURE_H */
