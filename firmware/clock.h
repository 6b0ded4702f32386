/*
 * clock.h - a slow clock for the console's line timeout: Timer0 free-running
 * at F_CPU / 1024, its overflow counted in GPIOR1 (an I/O register: no SRAM).
 * One tick is 256 * 1024 / F_CPU seconds (26.2 ms at 10 MHz); the count
 * wraps at 256 ticks (6.7 s), so callers compare differences only.  The
 * overflow interrupt also wakes a sleeping loop, so an open line's timeout
 * is seen within a tick even when sampling is stopped.
 */
#ifndef CLOCK_H
#define CLOCK_H

#include <stdint.h>

#define CLOCK_TICK_CYCLES (256UL * 1024UL)

void clock_init(void);

/* Ticks since power-up, modulo 256. */
uint8_t clock_now(void);

#endif /* CLOCK_H */
