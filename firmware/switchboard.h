/*
 * switchboard.h - the output scheduler, the one owner of the UART's
 * transmit side: like a switchboard, it connects one producer at a time
 * to the line (it was tx.h; it transmits nothing itself).
 * Every line leaves the device through it: the boot line and reports
 * (report.c), command replies (reply.c) and the sample stream (stream.c),
 * all written through the proto sink.
 *
 * Output never blocks the main loop.  One job (a reply, or a whole report)
 * runs at a time, interleaved with the stream; switchboard_poll() advances them in
 * steps of at most UART_STEP_MAX characters, each taken only when the TX
 * ring has room for it, so sampling goes on while a report drains and the
 * stack never holds a report and the Allan engine at once.
 */
#ifndef SWITCHBOARD_H
#define SWITCHBOARD_H

#include <stdint.h>

/* The proto sink becomes the UART. */
void switchboard_init(void);

/* Queue jobs (replies and echo only when switchboard_can_interject()). */
void switchboard_echo(void); /* the rest of the taken line's echo (console.h), whole */
void switchboard_boot(void);
void switchboard_report(void);                         /* a whole report, after the current job */
void switchboard_ok(const char *text_P);               /* `ok` or `ok <text>` */
void switchboard_ok_n(const char *text_P, uint32_t n); /* `ok <text><n>` */
void switchboard_ok_word(const char *text_P, const char *list_P, uint8_t n); /* `ok <text><word n of list>` */
/* `error:<code> <command>: <what>; <allowed>`: see reply_set_error(),
 * whose text_P says what is wrong and what is allowed.
 * switchboard_refuse: a line refused before any command is known (unknown word,
 * too long, bytes lost), naming its first word. */
void switchboard_error(uint8_t code, uint8_t id, const char *text_P);
void switchboard_refuse(uint8_t code, const char *line);
void switchboard_status(void); /* `ok status ...` */
void switchboard_help(void);   /* `ok help <command> <args>`, a line each */

/* 1 while a job or a stream line is being written. */
uint8_t switchboard_busy(void);

/* 1 when a command may run now and queue its reply: no job, or a report
 * between two of its lines (the report resumes after the reply), and no
 * stream line half written. */
uint8_t switchboard_can_interject(void);

/* Cut off the report in progress (no end line: readers discard it), e.g.
 * because the accumulators were just reset under it. */
void switchboard_abort_report(void);

/* A new run: the report in progress is cut off, the run identity changes. */
void switchboard_new_run(void);

/* The stream's rows count from 0 again, and a new run's rows wait for the
 * reply of the command that started it. */
void switchboard_restart_rows(void);

/* 1 when the TX ring takes a whole step now. */
uint8_t switchboard_can_write(void);

/* Write as much as the TX ring takes now. */
void switchboard_poll(void);

#endif /* SWITCHBOARD_H */
