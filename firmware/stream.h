/*
 * stream.h - the sample stream of modes raw, binary and both
 * (docs/protocol.md): a raw thesis row or a binary frame for each sample
 * set, and a count line `$C,<rows>,<drops>` every LINK_COUNT_EVERY of them.
 * A producer: the output scheduler (switchboard.c) gives it its turns; the
 * main loop asks it whether the oldest set may go to the engine yet, and
 * tells it when the engine has taken it (loop.c).
 */
#ifndef STREAM_H
#define STREAM_H

#include <stdint.h>

/* Rows and frames count from 0 again (mode entered, a new run). */
void stream_restart(void);

/* Not 0 while the oldest sampled set still has to be written (raw, binary
 * and both modes), so it must stay in the ADC ring for now. */
uint8_t stream_holds_oldest(void);

/* The oldest set went to the engine: the next one is due for output. */
void stream_taken(void);

/* 1 while a row or count line of the stream is half written: nothing else
 * may be written before it is finished. */
uint8_t stream_line_open(void);

/* 1 while a stream line is open or a count line is due. */
uint8_t stream_busy(void);

/* Write one step (at most UART_STEP_MAX bytes) if the stream has one:
 * the rest of an open line; a due count line or a raw row only when
 * at_boundary (no other line half written); a binary frame anywhere but
 * inside a count line (text never holds the frame's sync byte).  New sets
 * only when !held.  Returns 1 when it wrote something. */
uint8_t stream_step(uint8_t at_boundary, uint8_t held);

#endif /* STREAM_H */
