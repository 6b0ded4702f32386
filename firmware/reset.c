/*
 * reset.c - see reset.h.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <avr/wdt.h>

#include "reset.h"

#define RESET_CANARY 0x5EC0u  /* noise matches it 1 time in 65536 */
#define RESET_WDT_ARMED 0xA7u /* the marker: one pattern, not "non-zero" */
#define RESET_MCUSR_BITS ((1u << PORF) | (1u << EXTRF) | (1u << BORF) | (1u << WDRF))
/* optiboot's version word, at the very end of flash: major, minor */
#define RESET_BOOT_VERSION_ADDR (FLASHEND - 1u)
#define RESET_OPTIBOOT_R2_MAJOR 8u /* from optiboot 8 on, r2 holds MCUSR */
#ifndef RAMSTART
#  define RAMSTART 0x100u
#endif

/* Kept across warm resets: neither .data nor .bss, which the start-up
 * code overwrites after .init3.  Four bytes of SRAM. */
static uint16_t reset_canary __attribute__((section(".noinit")));
static volatile uint8_t reset_wdt_armed __attribute__((section(".noinit")));
static uint8_t reset_found __attribute__((section(".noinit")));

extern const char __data_load_end[]; /* end of the firmware's flash image */

/* 1 if SRAM from RAMSTART holds the firmware's last flash page: what
 * optiboot's page buffer holds right after writing it. */
static uint8_t reset_page_buffer_is_last_page(void)
{
  uint16_t page = ((uint16_t)__data_load_end - 1u) & (uint16_t) ~(SPM_PAGESIZE - 1u);
  const uint8_t *ram = (const uint8_t *)RAMSTART;
  uint8_t i = 0;
  do {
    if (ram[i] != pgm_read_byte(page + i))
      return 0;
  } while (++i < SPM_PAGESIZE);
  return 1;
}

/* Before anything clears MCUSR or SRAM (avr-libc's recipe).  The watchdog
 * stays enabled across its own reset (WDRF set): it is turned off here at
 * once, or it would bite again during start-up, and again: a loop. */
void reset_capture(void) __attribute__((naked, used, section(".init3")));
void reset_capture(void)
{
  uint8_t r2, cause;
  __asm__ volatile("mov %0, r2" : "=r"(r2));
  cause = MCUSR & RESET_MCUSR_BITS;
  MCUSR = 0;
  wdt_disable();
  if (!cause) {
    uint16_t boot_version = pgm_read_word(RESET_BOOT_VERSION_ADDR);
    if (boot_version != 0xFFFFu && (boot_version >> 8) >= RESET_OPTIBOOT_R2_MAJOR)
      cause = r2 & RESET_MCUSR_BITS;
  }
  if (!cause) {
    if (reset_canary != RESET_CANARY)
      cause = reset_page_buffer_is_last_page() ? 0 : RESET_POR;
    else if (reset_wdt_armed == RESET_WDT_ARMED)
      cause = RESET_WDT;
  }
  reset_found = cause;
  reset_canary = RESET_CANARY;
  reset_wdt_armed = 0;
}

uint8_t reset_cause(void)
{
  return reset_found;
}

/* The watchdog's interrupt comes first and only wakes the loop from sleep;
 * the loop re-arms it, a hung loop does not, and the next timeout resets:
 * the marker tells the next start. */
ISR(WDT_vect)
{
  reset_wdt_armed = RESET_WDT_ARMED;
}

void reset_watchdog_kick(void)
{
  wdt_reset();
  WDTCSR |= (1 << WDIE);
  reset_wdt_armed = 0;
}

void reset_watchdog_start(void)
{
  wdt_enable(WDTO_1S);
  reset_watchdog_kick();
}
