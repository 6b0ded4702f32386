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

uint16_t link_wait_bytes(uint8_t mode)
{
  /* if, not switch: a switch becomes a lookup table, in RAM on the AVR */
  if (mode == MODE_RAW)
    return LINK_REPLY_MAX + UART_STEP_MAX + LINK_RAW_ROW;
  if (mode == MODE_BOTH)
    return LINK_REPORT_MAX + UART_STEP_MAX + LINK_RAW_ROW;
  if (mode == MODE_BINARY)
    return UART_STEP_MAX + LINK_FRAME;
  return 0;
}

uint8_t link_fits(uint8_t mode, uint16_t fs, uint32_t baud)
{
  uint32_t usable = (baud / 10u) * LINK_USE_PERCENT; /* bytes per second, x100 */
  if (link_bytes_per_s(mode, fs) * 100u > usable)
    return 0;
  /* wait / (usable / 100) seconds <= 2 / fs */
  return (uint32_t)link_wait_bytes(mode) * fs * 100u <= 2u * usable;
}
