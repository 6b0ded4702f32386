/*
 * ref_crc16.h - the CRCs written bit by bit from their definitions
 * (docs/protocol.md): the line check CRC-16/CCITT-FALSE and the report's and
 * saved record's CRC-16/MODBUS; the tests' and fuzzers' own references, shared
 * by tests/firmware/native and tests/firmware/fuzz, independent of crc.c.
 */
#ifndef REF_CRC16_H
#define REF_CRC16_H

#include <stddef.h>
#include <stdint.h>

static inline unsigned ref_crc16(const char *s, size_t n)
{
  unsigned reg = 0xFFFF;
  for (size_t i = 0; i < n; i++)
    for (int b = 7; b >= 0; b--) {
      unsigned in = ((unsigned char)s[i] >> b) & 1u, top = (reg >> 15) & 1u;
      reg = (reg << 1) & 0xFFFF;
      if (top ^ in)
        reg ^= 0x1021;
    }
  return reg;
}

/* CRC-16/MODBUS continued from reg (reflected 0xA001, a bit at a time),
 * independent of firmware/crc.c's byte-wise update. */
static inline unsigned ref_crc16_modbus_more(unsigned reg, const uint8_t *p, size_t n)
{
  for (size_t i = 0; i < n; i++)
    for (int b = 0; b < 8; b++) {
      unsigned in = (p[i] >> b) & 1u, low = reg & 1u;
      reg >>= 1;
      if (low ^ in)
        reg ^= 0xA001;
    }
  return reg;
}

static inline unsigned ref_crc16_modbus(const uint8_t *p, size_t n)
{
  return ref_crc16_modbus_more(0xFFFF, p, n);
}

#endif /* REF_CRC16_H */
