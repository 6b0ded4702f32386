/*
 * report.h - the report lines (docs/protocol.md): the boot line B and a
 * report's header H, rows L, human summary S and end E.  A producer: the
 * output scheduler (switchboard.c) calls it one step at a time, each step writing at
 * most UART_STEP_MAX characters through the proto sink, and decides when a
 * report starts, pauses for a reply and resumes.
 */
#ifndef REPORT_H
#define REPORT_H

#include <stdint.h>

/* Before the first report (the `reset=` fields are reset.h's cause). */
void report_init(void);

/* One step of the boot line; returns 1 when the line is written. */
uint8_t report_boot_step(uint8_t step);

/* A new run (reset, or a rate or range change): `id=` changes. */
void report_new_run(void);

/* The next report starts from its header, with the next seq. */
void report_begin(void);

/* What report_step() has just done. */
#define REPORT_MORE 0      /* the line goes on: call again with step + 1 */
#define REPORT_LINE_DONE 1 /* a line is written: the next starts at step 0 */
#define REPORT_DONE 2      /* the end line is written: the report is whole */

/* One step of the current line of the report, the engine settled
 * (sample.h's sample_settle has nothing left to do). */
uint8_t report_step(uint8_t step);

#endif /* REPORT_H */
