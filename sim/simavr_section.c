/*
 * simavr_section.c - a `.mmcu` section that tells simavr the MCU and clock,
 * so the simulator harness runs the very ELF that is flashed.  Simulator
 * support, linked into the firmware ELF by sim/sim.mk.  The section lives
 * outside flash (the Makefile places it at 0x910000, away from .data, which
 * simavr 1.6 otherwise mis-loads) and is not part of the .hex.
 */
#ifdef HAVE_SIMAVR_SECTION
#  include <avr/avr_mcu_section.h>

#  include "config.h"

AVR_MCU(F_CPU, FW_MCU_NAME);
#else
typedef int simavr_section_unavailable; /* ISO C wants something here */
#endif
