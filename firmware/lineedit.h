/*
 * lineedit.h - a terminal's command line: typed bytes in, the line and
 * its echo out.  Pure (no I/O): control.c feeds it the received bytes and
 * writes the echo it asks for where the output allows.
 *
 * Editing: Backspace (0x08) and DEL (0x7F) erase the last character,
 * Ctrl-C (0x03) and Esc (0x1B) drop the line, CR or LF ends it.  Any
 * other byte outside printable ASCII and TAB (NUL, a control, 8-bit) takes
 * its place as '?' and the whole line is refused (error:6).
 * Echo (docs/protocol.md): an echoed line is `> <text>` CR LF, written
 * at the start of an output line; "\b \b" erases a shown character.  The
 * echo never holds '$' (shown as '?') nor a control byte, so that it can
 * never be taken for a protocol line.
 */
#ifndef LINEEDIT_H
#define LINEEDIT_H

#include <stdint.h>

#include "command.h" /* COMMAND_LINE_MAX */

/* lineedit_feed() results */
#define LINE_TYPING 0 /* the line goes on */
#define LINE_ENDED  1 /* a complete line is in text (len 0: blank) */
#define LINE_DROPPED 2 /* Ctrl-C or Esc: the line was thrown away */

/* flags: LINE_LONG, LINE_LOST, LINE_BYTE: the line is refused at its end */
#define LINE_LONG 1
#define LINE_LOST 2
#define LINE_DROP 4 /* dropped (Ctrl-C, Esc): its echo ends, then it goes */
#define LINE_ENDED_BIT 8 /* the line ended (or was dropped), its echo not yet finished */
#define LINE_OPEN 16 /* the echo line's "> " is out, its CR LF not yet */
#define LINE_RUN 32 /* the line has run: the end of its echo ends it */
#define LINE_READY 64 /* cmdline.c: the ended line waits for its turn to run */
#define LINE_BYTE 128 /* a byte no command holds (shown '?'): refused at its end */

typedef struct {
  char text[COMMAND_LINE_MAX + 1];
  uint8_t len;
  uint8_t flags;     /* LINE_* above */
  uint8_t shown;     /* characters of text on the terminal (echo) */
  uint8_t keep;      /* of them, still equal to text */
} lineedit_t;

/* The device's command line (one terminal): cmdline.c fills it, control.c
 * runs it, the output scheduler writes the rest of its echo (tx_echo). */
extern lineedit_t lineedit;

/* 1 while an ended line's echo is not finished; 1 while an echo line is open. */
#define lineedit_ended(l) (((l)->flags & LINE_ENDED_BIT) != 0)
#define lineedit_open(l) (((l)->flags & LINE_OPEN) != 0)
#define LINE_REFUSED (LINE_LONG | LINE_LOST | LINE_BYTE) /* refused at its end */

/* One received byte; `lost`: bytes were lost just before it. */
uint8_t lineedit_feed(lineedit_t *l, uint8_t c, uint8_t lost);

/* Write the echo due now, at most min(room, LINEEDIT_ECHO_MAX) bytes,
 * through put; returns the count (0: nothing due or no room).  `final`: echo nothing until the
 * line has ended, then all of it at once (output that must not be cut). */
#define LINEEDIT_ECHO_MAX (2u + COMMAND_LINE_MAX + 2u)
uint8_t lineedit_echo(lineedit_t *l, uint8_t final, void (*put)(uint8_t c), uint8_t room);

/* 1 when there is no line at all: nothing typed, nothing shown, no
 * flag; lineedit_echo() has nothing to do (a cheap test for the main
 * loop, which would otherwise call it on every pass). */
#define lineedit_idle(l) (!((l)->len | (l)->shown | (l)->flags))

/* How a typed character is shown (echo, quoted in an error): '?' for a
 * control byte, '$' or '*', which would spoil a protocol line. */
char lineedit_shown_as(char c);

/* The line is taken (run or refused): the next one starts. */
void lineedit_next(lineedit_t *l);

#endif /* LINEEDIT_H */
