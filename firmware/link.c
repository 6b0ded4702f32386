/* link.c - see link.h. */
#include "link.h"

#include "config.h"

#include "pgm.h"

uint32_t link_bytes_per_s(uint8_t mode, uint16_t fs)
{
  return LINK_BYTES_PER_S(mode, (uint32_t)fs); /* allan: only reports, which wait for the link */
}

uint16_t link_percent(uint8_t mode, uint16_t fs, uint32_t baud)
{
  return LINK_PERCENT(mode, (uint32_t)fs, baud);
}

uint16_t link_wait_bytes(uint8_t mode)
{
  return LINK_WAIT_BYTES(mode);
}

uint8_t link_fits(uint8_t mode, uint16_t fs, uint32_t baud)
{
  return LINK_FITS(mode, (uint32_t)fs, baud);
}

#ifdef BAUD
/* By rate, in vocab_rates' order: the percent of raw and both (the same
 * rows), of binary, and which modes fit (bit MODE_*). */
#  define LINK_ENTRY(baud, hz)                                                                               \
    {LINK_PERCENT(MODE_RAW, hz##ul, baud), LINK_PERCENT(MODE_BINARY, hz##ul, baud),                          \
     (uint8_t)((1u << MODE_ALLAN) | (LINK_FITS(MODE_RAW, hz##ul, baud) ? 1u << MODE_RAW : 0u) |              \
               (LINK_FITS(MODE_BINARY, hz##ul, baud) ? 1u << MODE_BINARY : 0u) |                             \
               (LINK_FITS(MODE_BOTH, hz##ul, baud) ? 1u << MODE_BOTH : 0u))},
static const struct {
  uint16_t rows, frames;
  uint8_t fits;
} budget[VOCAB_RATE_COUNT] PROGMEM = {VOCAB_RATES(LINK_ENTRY, BAUD)};

uint8_t link_fits_here(uint8_t mode, uint16_t fs)
{
  uint8_t i = vocab_rate_index(fs);
  return i < VOCAB_RATE_COUNT && ((pgm_read_byte(&budget[i].fits) >> mode) & 1u);
}

uint16_t link_percent_here(uint8_t mode, uint16_t fs)
{
  uint8_t i = vocab_rate_index(fs);
  if (i == VOCAB_RATE_COUNT || mode == MODE_ALLAN)
    return 0;
  return pgm_read_word(mode == MODE_BINARY ? &budget[i].frames : &budget[i].rows);
}
#endif

/* The default mode must keep up with the link at the default rate: the
 * rules of link.c (throughput, and the longest wait of a sample's output,
 * replies and reports included, within two sample periods), at compile
 * time. */
#ifdef BAUD
#  if MODE_DEFAULT == MODE_RAW || MODE_DEFAULT == MODE_BOTH
#    define CONFIG_LINK_BYTES                                                                                \
      (FS_DEFAULT * LINK_RAW_ROW + (FS_DEFAULT * LINK_COUNT_LINE) / LINK_COUNT_EVERY + 1)
#    if MODE_DEFAULT == MODE_RAW
#      define CONFIG_LINK_WAIT (LINK_REPLY_MAX + UART_STEP_MAX + LINK_RAW_ROW)
#    else
#      define CONFIG_LINK_WAIT (LINK_REPORT_MAX + UART_STEP_MAX + LINK_RAW_ROW)
#    endif
#  elif MODE_DEFAULT == MODE_BINARY
#    define CONFIG_LINK_BYTES                                                                                \
      (FS_DEFAULT * LINK_FRAME + (FS_DEFAULT * LINK_COUNT_LINE) / LINK_COUNT_EVERY + 1)
#    define CONFIG_LINK_WAIT (UART_STEP_MAX + LINK_FRAME)
#  else
#    define CONFIG_LINK_BYTES 0
#    define CONFIG_LINK_WAIT 0
#  endif
#  if CONFIG_LINK_BYTES * 100 > (BAUD / 10) * LINK_USE_PERCENT
#    error "MODE_DEFAULT at FS_DEFAULT sends more than the link carries at BAUD"
#  endif
#  if CONFIG_LINK_WAIT * FS_DEFAULT * 100 > 2 * (BAUD / 10) * LINK_USE_PERCENT
#    error "MODE_DEFAULT at FS_DEFAULT: a long line would hold samples back beyond the ring's slack at BAUD"
#  endif
#endif
