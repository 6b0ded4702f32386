/*
 * reset.h - why the MCU last reset, told honestly under a bootloader, and
 * the watchdog that resets it when the loop hangs.
 *
 * The cause is a set of MCUSR bits (RESET_POR ... RESET_WDT); an empty set
 * means "unknown" (a warm reset whose cause nothing recorded), never
 * "none".  Where they come from, best first:
 *  - MCUSR, read in .init3 before anything clears it (no bootloader, or
 *    one that leaves it alone);
 *  - r2, where the bootloader hands MCUSR over (optiboot 8 and later, told
 *    by the version word optiboot keeps at the end of flash);
 *  - otherwise (Debian's optiboot 4.4 reads MCUSR, clears it and jumps to
 *    the firmware): a canary in .noinit SRAM, which a power-on leaves as
 *    noise and any other reset keeps, tells power-on from a warm reset;
 *    a marker set when the watchdog's last warning went unanswered tells
 *    the firmware's own watchdog reset (not a hang with interrupts off,
 *    where the warning cannot run); a warm reset without it is "unknown"
 *    (the RESET pin, DTR, the bootloader's own watchdog ...).
 *    A firmware just written through the bootloader finds the canary
 *    gone too; optiboot's page buffer (SRAM from RAMSTART), still equal
 *    to the firmware's last flash page, tells it: "unknown", not power-on.
 */
#ifndef RESET_H
#define RESET_H

#include <stdint.h>

#define RESET_POR (1u << 0) /* MCUSR's PORF, EXTRF, BORF, WDRF */
#define RESET_EXT (1u << 1)
#define RESET_BOR (1u << 2)
#define RESET_WDT (1u << 3)

/* The cause of the last reset (0: unknown), as found in .init3. */
uint8_t reset_cause(void);

/* The watchdog: about a second without reset_watchdog_kick() brings its
 * interrupt (which only wakes the loop), a second more a reset. */
void reset_watchdog_start(void);
void reset_watchdog_kick(void);

#endif /* RESET_H */
