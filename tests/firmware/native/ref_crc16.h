/*
 * ref_crc16.h - the line check CRC-16/CCITT-FALSE written bit by bit from its
 * definition (docs/protocol.md): the tests' and fuzzers' own reference, shared
 * by tests/firmware/native and tests/firmware/fuzz, independent of crc.c.
 */
#ifndef REF_CRC16_H
#define REF_CRC16_H

#include <stddef.h>

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

#endif /* REF_CRC16_H */
