/*
 * clock.h - a slow clock for the console's line timeout: Timer0 free-running
 * at F_CPU / 1024, its overflows counted in GPIOR1 (an I/O register: no
 * SRAM) since the last clock_restart(), up to 255.  One tick is 256 * 1024
 * / F_CPU seconds (26.2 ms at 10 MHz).  The overflow interrupt also wakes a
 * sleeping loop, so an open line's timeout is seen within a tick even when
 * sampling is stopped.
 */
#ifndef CLOCK_H
#define CLOCK_H

#include <stdint.h>

#define CLOCK_TICK_CYCLES (256UL * 1024UL)

void clock_init(void);

/* Ticks since the last clock_restart() (or power-up), at most 255. */
uint8_t clock_ticks(void);
void clock_restart(void);

#endif /* CLOCK_H */
