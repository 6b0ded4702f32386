/*
 * sample.h - the main loop's side of sampling: drains finished scans into
 * the Allan engine and keeps the per-run and per-report statistics.
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

/* Feed every finished scan the stream no longer holds to the engine and
 * the statistics.  Called by the main loop, and by commands that must see
 * every set taken so far; never by the output code.  Cheap when there is
 * none. */
void sample_feed(void);

/* Clear the engine, clips and drops (a new run). */
void sample_reset(void);

/* Start a new report interval (temperature statistics and the periodic
 * report's sample count). */
void sample_interval_restart(void);

#endif /* SAMPLE_H */
