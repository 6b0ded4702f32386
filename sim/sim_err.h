/*
 * sim_err.h - one line of error text into a caller's buffer: how imu-sim's
 * helpers (sim_rows.c, sim_term.c) report a failure to their caller.
 */
#ifndef SIM_ERR_H
#define SIM_ERR_H

#include <stddef.h>

void err_set(char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

#endif /* SIM_ERR_H */
