/*
 * console.h - the conversation with a terminal or a host (docs/protocol.md,
 * "Commands"): received bytes assembled into one command line at a time,
 * its editing (Backspace, DEL, Ctrl-C, Esc), its echo, the line's timeout,
 * and the line waiting to run until its reply may be written.  Called from
 * the main loop only (control.c; the output scheduler writes the rest of an
 * echo as a job of its own).  Pure: no <avr/io.h>; it reads the UART and the
 * clock through uart.h and clock.h, faked in the native tests.
 *
 * The line discipline:
 *  - CR or LF ends a line; blank lines are ignored.
 *  - A line is refused whole, never run cut short nor glued to the next:
 *    bytes lost on the way in (a data overrun, the RX ring full) before any
 *    of its bytes or its end: error:5; no end within CONSOLE_TIMEOUT_MS of
 *    silence: error:7; a byte outside printable ASCII and TAB: error:6;
 *    longer than COMMAND_LINE_MAX: error:3 (5 outranks 7, which outranks
 *    the others; between 6 and 3 the first found).
 *  - A line may end in its check, `*XXXX`: the CRC-16 of the text before
 *    `*` (crc.h, the lines' own) in upper-case hex; not exactly that
 *    (a bit flipped on the way, a malformed check): error:5, counted as a
 *    lost line.  The check is neither kept in the text (not counted in
 *    COMMAND_LINE_MAX) nor echoed.
 *  - Ctrl-C (0x03) and Esc (0x1B) drop the line at once, bytes lost with
 *    it; reading goes on (a command right after it runs).  A dropped line
 *    that is on the screen ends with `^C` CR LF.
 *  - Echo (settings.echo): `> <text>` CR LF as a line of its own; typed
 *    characters shown as they come when the caller says the output is
 *    free (live), else the whole line once it has ended, just before its
 *    reply.  "\b \b" erases a shown character.  The echo never holds '$',
 *    '*' or a control byte (shown '?'): it can never pass for a protocol
 *    line.  Other output starts on a fresh line: console_close() first.
 */
#ifndef CONSOLE_H
#define CONSOLE_H

#include <stdint.h>

#include "config.h"

/* Move received bytes into the line, until one is complete (cheap: the
 * main loop calls it between two sample sets). */
void console_receive(void);

/* console_receive(), then the timeout of an open line, then, `live`, the
 * echo of what was typed (the output is free for it: nothing else being
 * written, mode allan). */
void console_poll(uint8_t live);

/* 1 when a complete (or refused) line waits to run. */
uint8_t console_ready(void);

/* Take the waiting line: returns 0 and sets *text (NUL-terminated; parse
 * it at once, before the next console_receive()), or the error code that
 * refuses it (CMD_ERR_LOST, CMD_ERR_TIMEOUT, CMD_ERR_BYTE, CMD_ERR_LONG;
 * *text set too, for the error's quote).  Echo on: the rest of the line's
 * echo is due (console_echo_job()) before the next line is read. */
uint8_t console_take(const char **text);

/* The output scheduler's echo job, before the reply: write the rest of
 * the taken line's echo (at most UART_STEP_MAX bytes a call, only when the
 * TX ring has that room); 1 when it is all out. */
uint8_t console_echo_job(void);

/* End the echo line on the screen, if any (CR LF; a dropped line's `^C`
 * first), so that other output (a report, a reply not to this line)
 * starts at a line's beginning; what was typed is shown again, whole, on
 * a fresh echo line later.  1 when no echo line is open any more (0: no
 * room in the TX ring yet, try again). */
uint8_t console_close(void);

/* The receive counters since power-up, saturating at 65535, in the order
 * of `rx=` (status, report header): gaps in the received bytes due to a
 * UART data overrun, gaps due to the full RX ring (each gap one or more
 * bytes; gaps that come while an earlier one waits to be read count
 * once), lines refused for lost bytes or a wrong check (error:5), lines timed out
 * (error:7). */
#define CONSOLE_COUNTS 4

/* Write count i of `rx=` through the proto sink, the key first (after
 * sep) for i = 0, ':' before the others: at most 7 characters. */
void console_put_count(uint8_t i, char sep);

/* How a typed character is shown (echo, the quote of an error): '?' for a
 * control byte, '$' or '*', which would spoil a protocol line. */
char console_shown_as(char c);

#endif /* CONSOLE_H */
