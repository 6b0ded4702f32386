/*
 * loop.h - one pass of the main loop's work, and whether there is more:
 * main.c runs it between sleeps, the native tests and fuzz_line against
 * their fakes (one copy of the loop for all three).
 *
 * The sample path is a straight line, each step called from here: a
 * finished scan waits in the ADC ring; in modes raw, binary and both the
 * stream writes it first (through the output scheduler); then the engine
 * takes it (sample.c) and the stream is told.  Nothing on the path calls
 * back up: a report's header that has written its interval's temperature
 * raises a flag (board.h's BOARD_FLAG_INTERVAL), and this pass starts the
 * next interval before it takes another set.
 */
#ifndef LOOP_H
#define LOOP_H

#include <stdint.h>

/* Sets to the engine, received bytes to the console, the engine's waiting
 * work, the output, the commands.  Returns 1 when it did a piece of the
 * engine's waiting work and left the rest of the pass for the next one
 * (run it again at once: no sleep). */
uint8_t loop_pass(void);

/* Work a pass can do right now; without any, the device sleeps until an
 * interrupt (a tick, a conversion, a byte in or out) brings some. */
uint8_t loop_has_work(void);

#endif /* LOOP_H */
