/*
 * crc.h - CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, MSB first, no xor),
 * the checksum of every protocol line.  "123456789" gives 0x29B1.
 */
#ifndef CRC_H
#define CRC_H

#include <stdint.h>

#define CRC16_INIT 0xFFFFu

uint16_t crc16_update(uint16_t crc, uint8_t byte);

#endif /* CRC_H */
