/*
 * sim_drive.h - the batch run (without --pty): set-up commands, the rows,
 * the final report.
 */
#ifndef SIM_DRIVE_H
#define SIM_DRIVE_H

#include "harness.h"

void drive_connect(harness_t *h); /* takes the serial and ADC hooks */
int drive_run(harness_t *h);      /* the run; returns avr_run()'s state */
void drive_summary(harness_t *h, int code); /* warnings, at its end */

#endif /* SIM_DRIVE_H */
