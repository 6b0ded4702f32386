/*
 * sim_msg.h - imu-sim's messages: warnings, fatal errors, failures found
 * inside simavr callbacks, simavr's own log.
 */
#ifndef SIM_MSG_H
#define SIM_MSG_H

#include <stdarg.h>

#include "harness.h"

/* simavr's log goes through logger(), which reads h's verbosity. */
void msg_init(harness_t *h);
void warn(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void die(int code, const char *fmt, ...)
    __attribute__((format(printf, 2, 3), noreturn));
/* A failure found inside a simavr callback: the run loop stops on it. */
void fail(harness_t *h, int code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
double sim_time(const harness_t *h);
void logger(avr_t *avr, const int level, const char *fmt, va_list ap);

#endif /* SIM_MSG_H */
