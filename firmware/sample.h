/*
 * sample.h - the main loop's side of sampling: drains finished scans into
 * the Allan engine and keeps the per-run and per-report statistics.  It
 * reads the ADC ring and calls nothing else: which set may go when (the
 * stream's rows first) and when a report interval ends are the main
 * loop's to say (loop.h).
 */
#ifndef SAMPLE_H
#define SAMPLE_H

#include <stdint.h>

#include "adc.h"
#include "allan.h"

typedef struct {
  uint16_t clips[ADC_COLUMNS]; /* codes at 0 or 1023 since the last reset (saturating) */
  uint32_t since_report;       /* sample sets in the current report interval */
  uint32_t temp_sum;           /* temperature over the current report interval: */
  uint8_t temp_sum_hi;         /* its bits 32..39 (an hour at 1500 Hz of codes up to 1023: 5.5e9) */
  uint16_t temp_min, temp_max;
} sample_stats_t;

extern allan_t sample_engine;
extern sample_stats_t sample_stats;

/* Feed the oldest finished scan (one must wait: adc_pending()) to the
 * engine and the statistics, and remove it from the ring.  The main loop
 * calls it a set at a time, receiving command bytes between two sets (a
 * set takes at most 0.4 ms, the RX ring lasts 0.69 ms at 115200 baud). */
void sample_take(void);

/* One piece of the engine's waiting work (a set's lagging channels, a
 * level's deferred pairs: allan.h), 1 if there was one.  The main loop
 * calls it while no set waits, until it returns 0, before the output's
 * turn: the reports read a settled engine and never compute for it, and
 * the loop takes a waiting set between two pieces. */
uint8_t sample_settle(void);

/* Clear the engine, clips and drops (a new run). */
void sample_reset(void);

/* Start a new report interval (temperature statistics and the periodic
 * report's sample count): a new run, and the report's header once it has
 * written the interval's temperature (the loop's pass, told so by the
 * header's flag: loop.h). */
void sample_interval_restart(void);

#endif /* SAMPLE_H */
