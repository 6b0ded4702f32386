/* Native stand-in for <avr/eeprom.h>: a 512-byte array (fake_eeprom.c). */
#ifndef FAKE_AVR_EEPROM_H
#define FAKE_AVR_EEPROM_H

#include <stddef.h>
#include <stdint.h>

#define E2END 511
extern uint8_t fake_eeprom[E2END + 1];
void eeprom_read_block(void *dst, const void *src, size_t n);
void eeprom_update_byte(uint8_t *addr, uint8_t value);
int eeprom_is_ready(void);

#endif
