/*
 * sim_termrun.h - terminal mode (--pty): the device's port on a pty.
 */
#ifndef SIM_TERMRUN_H
#define SIM_TERMRUN_H

#include <time.h>

#include "harness.h"

void term_open(harness_t *h); /* the pty, its link and the info stream */
int term_run(harness_t *h);
void term_started(struct timespec *t0); /* when the device powered up */
void term_summary(harness_t *h, int st);
void term_close(void);

#endif /* SIM_TERMRUN_H */
