/*
 * Native stand-in for <avr/io.h>: the few I/O registers the firmware's
 * portable modules touch (board.h's g-select and probe pins) are plain
 * bytes here, so a test can read the pins the control room drives.
 */
#ifndef FAKE_AVR_IO_H
#define FAKE_AVR_IO_H

#include <stdint.h>

extern volatile uint8_t fake_ddrb, fake_portb, fake_ddrd, fake_portd;
#define DDRB fake_ddrb
#define PORTB fake_portb
#define DDRD fake_ddrd
#define PORTD fake_portd
extern volatile uint8_t fake_gpior0, fake_gpior2; /* board.h's BOARD_FLAGS, BOARD_SPARE_REG */
#define GPIOR0 fake_gpior0
#define GPIOR2 fake_gpior2
#define PB0 0
#define PB1 1
#define PB2 2
#define PD6 6
#define PD7 7
#define REFS0 6
#define ADPS0 0
#define ADPS1 1
#define ADPS2 2
#define CS11 1

#endif
