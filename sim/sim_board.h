/*
 * sim_board.h - board mode (--board): flash and EEPROM kept in files, a
 * bootloader, the reset on opening the port.
 */
#ifndef SIM_BOARD_H
#define SIM_BOARD_H

#include "harness.h"

void board_open(harness_t *h); /* flash, EEPROM, bootloader, reset vector */
void board_external_reset(harness_t *h);
void board_poll(harness_t *h); /* persist what changed; SIGUSR1 hang */
void board_close(harness_t *h);

#endif /* SIM_BOARD_H */
