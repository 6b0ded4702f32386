/*
 * fuzz_util.h - shared helpers of the libFuzzer targets: a byte reader over
 * the fuzz input and a failure macro that prints why, then aborts (libFuzzer
 * saves the input as a crash artifact).
 */
#ifndef FUZZ_UTIL_H
#define FUZZ_UTIL_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#define FUZZ_CHECK(cond, ...)                                                                                \
  do {                                                                                                       \
    if (!(cond)) {                                                                                           \
      fprintf(stderr, "\n%s:%d: check failed: %s\n  ", __FILE__, __LINE__, #cond);                           \
      fprintf(stderr, __VA_ARGS__);                                                                          \
      fprintf(stderr, "\n");                                                                                 \
      abort();                                                                                               \
    }                                                                                                        \
  } while (0)

/* Reads the input front to back; past its end every read gives zeros. */
typedef struct {
  const uint8_t *p;
  size_t n;
} fuzz_in_t;

static inline uint8_t fz_u8(fuzz_in_t *in)
{
  if (!in->n)
    return 0;
  in->n--;
  return *in->p++;
}

static inline uint16_t fz_u16(fuzz_in_t *in)
{
  uint16_t v = fz_u8(in);
  return (uint16_t)(v | (uint16_t)fz_u8(in) << 8);
}

static inline uint32_t fz_u32(fuzz_in_t *in)
{
  uint32_t v = fz_u16(in);
  return v | (uint32_t)fz_u16(in) << 16;
}

#endif /* FUZZ_UTIL_H */
