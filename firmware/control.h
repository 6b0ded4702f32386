/*
 * control.h - the control room: command lines in from the UART, their
 * execution, the settings put in force (sample rate, accelerometer range
 * pins, output mode, report interval) and saved, and the periodic report.
 * Replies go out through the output scheduler (switchboard.h).
 */
#ifndef CONTROL_H
#define CONTROL_H

#include <stdint.h>

/* Load the settings (EEPROM or defaults), put them in force, start a run. */
void control_init(void);

/* Receive, run the command lines that are complete, advance an EEPROM
 * save, start a periodic report when its interval is full. */
void control_poll(void);

/* 1 when control_poll() has something to do now. */
uint8_t control_has_work(void);

#endif /* CONTROL_H */
