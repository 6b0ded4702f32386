/*
 * crc.h - CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, MSB first, no xor),
 * the checksum of every protocol line.  "123456789" gives 0x29B1.
 */
#ifndef CRC_H
#define CRC_H

#include <stdint.h>

#define CRC16_INIT 0xFFFFu

uint16_t crc16_update(uint16_t crc, uint8_t byte);

/* CRC-16/MODBUS (poly 0x8005 reflected = 0xA001, init 0xFFFF, LSB first,
 * no xor; avr-libc's _crc16_update): the EEPROM record's check, and the
 * second line of defence of reports (`V`) and raw rows (`C`), a polynomial
 * other than the lines' own.  "123456789" gives 0x4B37. */
#define CRC16_MODBUS_INIT 0xFFFFu
uint16_t crc16_modbus_update(uint16_t crc, uint8_t byte);

#endif /* CRC_H */
