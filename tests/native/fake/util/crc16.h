/* Native stand-in for avr-libc's <util/crc16.h>: _crc16_update is
 * CRC-16 with the reflected polynomial 0xA001, as avr-libc documents it. */
#ifndef FAKE_UTIL_CRC16_H
#define FAKE_UTIL_CRC16_H

#include <stdint.h>

static inline uint16_t _crc16_update(uint16_t crc, uint8_t a)
{
  int i;
  crc ^= a;
  for (i = 0; i < 8; ++i)
    crc = (crc & 1) ? (uint16_t)((crc >> 1) ^ 0xA001) : (uint16_t)(crc >> 1);
  return crc;
}

#endif
