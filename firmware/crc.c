/* crc.c - see crc.h.  On the AVR, avr-libc's XMODEM step is the same
 * polynomial, MSB first, in a few instructions; the host uses the loop. */
#include "crc.h"

#ifdef __AVR__
#  include <util/crc16.h>
#endif

uint16_t crc16_update(uint16_t crc, uint8_t byte)
{
#ifdef __AVR__
  return _crc_xmodem_update(crc, byte);
#else
  uint8_t i;
  crc ^= (uint16_t)byte << 8;
  for (i = 0; i < 8; i++)
    crc = (crc & 0x8000u) ? (uint16_t)((crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
  return crc;
#endif
}

uint16_t crc16_modbus_update(uint16_t crc, uint8_t byte)
{
#ifdef __AVR__
  return _crc16_update(crc, byte);
#else
  uint8_t i;
  crc ^= byte;
  for (i = 0; i < 8; i++)
    crc = (crc & 1u) ? (uint16_t)((crc >> 1) ^ 0xA001u) : (uint16_t)(crc >> 1);
  return crc;
#endif
}
