/* link.c - see link.h. */
#include "link.h"


uint32_t link_bytes_per_s(uint8_t mode, uint16_t fs)
{
  switch (mode) {
  case MODE_RAW:
  case MODE_BOTH:
    return (uint32_t)fs * LINK_RAW_ROW + ((uint32_t)fs * LINK_COUNT_LINE + LINK_COUNT_EVERY - 1u) / LINK_COUNT_EVERY;
  case MODE_BINARY:
    return (uint32_t)fs * LINK_FRAME + ((uint32_t)fs * LINK_COUNT_LINE + LINK_COUNT_EVERY - 1u) / LINK_COUNT_EVERY;
  default:
    return 0; /* allan: only reports, which wait for the link */
  }
}

uint16_t link_percent(uint8_t mode, uint16_t fs, uint32_t baud)
{
  uint32_t cap = baud / 10u;
  return (uint16_t)((link_bytes_per_s(mode, fs) * 100u + cap - 1u) / cap);
}

uint8_t link_fits(uint8_t mode, uint16_t fs, uint32_t baud)
{
  uint32_t cap = baud / 10u;
  uint32_t longest = mode == MODE_BOTH ? LINK_REPORT_MAX
                    : mode == MODE_RAW ? LINK_REPLY_MAX : UART_STEP_MAX + LINK_FRAME;
  if (mode == MODE_ALLAN)
    return 1;
  if (link_bytes_per_s(mode, fs) * 100u > cap * LINK_USE_PERCENT)
    return 0;
  /* longest / cap seconds <= 2 / fs */
  return longest * fs <= 2u * cap;
}
