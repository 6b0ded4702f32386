/*
 * report.h - the device's output lines (docs/protocol.md): boot line,
 * reports (header, rows, human summary, end) and command replies.
 */
#ifndef REPORT_H
#define REPORT_H

#include <stdint.h>

/* MCUSR bits captured at boot, for the `reset=` field. */
void report_init(uint8_t reset_cause);

void report_boot(void);

/* A whole report; sampling goes on while it drains. */
void report_send(void);

/* `ok`, `ok <detail>` (detail from flash, may be 0). */
void report_ok(const char *detail_P);

/* `ok <detail><n>`, e.g. "ok stopped n=" 1234. */
void report_ok_n(const char *detail_P, uint32_t n);

/* `error:<code> <reason>` (reason from flash). */
void report_error(uint8_t code, const char *reason_P);

#endif /* REPORT_H */
