/*
 * link.h - the serial link budget of each output mode (docs/protocol.md):
 * can the mode's worst-case output at a sample rate keep up with BAUD?
 * Pure: used at run time by `rate`/`mode` and by the unit tests; config.h
 * applies the same rules to the defaults at compile time.
 */
#ifndef LINK_H
#define LINK_H

#include <stdint.h>

#include "config.h" /* UART_STEP_MAX */
#include "vocab.h"  /* MODE_* */

/* Worst-case bytes of one raw row ("1023\t" x 6, "1023\r\n") and of the
 * count line sent every LINK_COUNT_EVERY rows or frames
 * ("$C,4294967295,4294967295,XXXX*XXXX\r\n"). */
#define LINK_RAW_ROW 36u
#define LINK_COUNT_LINE 36u
#define LINK_COUNT_EVERY 100u
#define LINK_FRAME 13u      /* one binary frame */
#define LINK_REPLY_MAX 131u /* longest reply line: status, with every field at its longest (rx= included) */
#define LINK_REPORT_MAX                                                                                      \
  313u /* longest report line: the header with every count at its maximum (rx= included) */
#define LINK_USE_PERCENT 90u /* of BAUD/10 bytes per second, at most */

/* The rules, as expressions of constants when their arguments are (the
 * device's table below, config.h's check of the defaults), and the
 * functions that apply them to any mode, rate and baud (the unit tests). */
#define LINK_COUNT_BYTES_(fs) (((fs) * (uint32_t)LINK_COUNT_LINE + LINK_COUNT_EVERY - 1u) / LINK_COUNT_EVERY)
#define LINK_BYTES_PER_S(mode, fs)                                                                           \
  ((mode) == MODE_RAW || (mode) == MODE_BOTH ? (fs) * (uint32_t)LINK_RAW_ROW + LINK_COUNT_BYTES_(fs) :       \
   (mode) == MODE_BINARY                     ? (fs) * (uint32_t)LINK_FRAME + LINK_COUNT_BYTES_(fs) :         \
                                               0u)
#define LINK_WAIT_BYTES(mode)                                                                                \
  ((mode) == MODE_RAW    ? LINK_REPLY_MAX + UART_STEP_MAX + LINK_RAW_ROW :                                   \
   (mode) == MODE_BOTH   ? LINK_REPORT_MAX + UART_STEP_MAX + LINK_RAW_ROW :                                  \
   (mode) == MODE_BINARY ? UART_STEP_MAX + LINK_FRAME :                                                      \
                           0u)
#define LINK_PERCENT(mode, fs, baud)                                                                         \
  ((uint16_t)((LINK_BYTES_PER_S(mode, fs) * 100u + (baud) / 10u - 1u) / ((baud) / 10u)))
#define LINK_FITS(mode, fs, baud)                                                                            \
  (LINK_BYTES_PER_S(mode, fs) * 100u <= ((baud) / 10u) * LINK_USE_PERCENT &&                                 \
   (uint32_t)LINK_WAIT_BYTES(mode) * (fs)*100u <= 2u * ((baud) / 10u) * LINK_USE_PERCENT)

/* Bytes per second the mode sends at rate fs, worst case, reports aside. */
uint32_t link_bytes_per_s(uint8_t mode, uint16_t fs);

/* Percent of the link (BAUD/10 bytes per second) the mode uses, rounded up. */
uint16_t link_percent(uint8_t mode, uint16_t fs, uint32_t baud);

/* Worst-case bytes that can stand between a sample set's arrival and the
 * end of its own row or frame: raw rows wait for a whole line (the longest
 * reply, or in `both` the longest report line) behind one output step
 * already in the TX ring, then go out themselves; binary frames cut into
 * text, so they wait one output step at most.  0 in mode allan. */
uint16_t link_wait_bytes(uint8_t mode);

/* 1 when the mode keeps up, replies and reports included: its throughput
 * stays within LINK_USE_PERCENT of the link, and link_wait_bytes() go out
 * within two sample periods (the slack of the two-set sample ring) at the
 * same LINK_USE_PERCENT, so that no reply and no report line ever costs a
 * sample set. */
uint8_t link_fits(uint8_t mode, uint16_t fs, uint32_t baud);

#ifdef BAUD
/* The same at the build's BAUD, for the supported rates (vocab.h), from a
 * table the compiler works out: no 32-bit arithmetic on the device.  A
 * rate that is not supported does not fit (percent 0). */
uint8_t link_fits_here(uint8_t mode, uint16_t fs);
uint16_t link_percent_here(uint8_t mode, uint16_t fs);
#endif

#endif /* LINK_H */
