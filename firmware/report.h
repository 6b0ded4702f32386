/*
 * report.h - the device's output (docs/protocol.md): boot line, reports
 * (header, rows, human summary, end) and command replies.
 *
 * Output never blocks the main loop.  One job (a reply, or a whole report)
 * runs at a time; report_poll() advances it in steps of at most
 * REPORT_STEP_MAX characters, each taken only when the TX ring has room for
 * it, so sampling goes on while a report drains and the stack never holds
 * a report and the Allan engine at once.
 */
#ifndef REPORT_H
#define REPORT_H

#include <stdint.h>

/* Most characters one step writes; the UART's TX ring holds more. */
#define REPORT_STEP_MAX 20

/* MCUSR bits captured at boot, for the `reset=` fields. */
void report_init(uint8_t reset_cause);

/* Queue jobs (only when report_can_interject()). */
void report_boot(void);
void report_start(void);                         /* a whole report, after the current job */
void report_ok(const char *text_P);              /* `ok` or `ok <text>` */
void report_ok_n(const char *text_P, uint32_t n); /* `ok <text><n>` */
void report_error(uint8_t code, const char *text_P);

void report_status(void);                        /* `ok status ...` */
void report_help(void);                          /* `ok help ...` */

/* 1 while a job or a raw row is being written. */
uint8_t report_busy(void);

/* 1 when a command may run now and queue its reply: no job, or a report
 * between two of its lines (the report resumes after the reply). */
uint8_t report_can_interject(void);

/* Cut off the report in progress (no end line: readers discard it), e.g.
 * because the accumulators were just reset under it. */
void report_abort(void);

/* Raw and binary modes: 1 while the oldest sampled set still has to be
 * written, so the main loop must leave it in the ring for now. */
uint8_t report_holds_sample(void);

/* The main loop took the oldest set: the next one is due for output. */
void report_sample_taken(void);

/* Restart the count of rows or frames (mode entered, accumulators reset). */
void report_restart_rows(void);

/* Write as much of the current job as the TX ring takes now. */
void report_poll(void);

#endif /* REPORT_H */
