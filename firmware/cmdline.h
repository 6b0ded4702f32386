/*
 * cmdline.h - the command-line receiver: bytes from the UART's RX ring
 * assembled into one line at a time (docs/protocol.md, "Commands").
 *
 * The RX ring holds 8 bytes, 0.69 ms at 115200 baud, while one sample set
 * can keep the engine busy for 1.5 ms (its octave cascade), so the ring is
 * drained not only by the loop but also between two channels of a set
 * (sample.c): a command of any allowed length arrives whole at any rate.
 */
#ifndef CMDLINE_H
#define CMDLINE_H

#include <stdint.h>

/* Move received bytes into the line (lineedit: the editor and its echo)
 * until it is complete.  BS and DEL erase the last character, Ctrl-C and
 * Esc drop the line; a line with any other byte outside printable ASCII
 * and TAB is refused whole, as is one that lost bytes or is too long. */
void cmdline_poll(void);

/* 1 when a complete line waits to be run. */
uint8_t cmdline_ready(void);

/* Take the complete line: returns 0 and sets *text (NUL-terminated; parse
 * it before the next cmdline_poll, which may start the next line in the
 * same buffer), or the error code that refuses it (CMD_ERR_LONG,
 * CMD_ERR_LOST, CMD_ERR_BYTE; *text is set too, for the error's quote). */
uint8_t cmdline_take(const char **text);

#endif /* CMDLINE_H */
