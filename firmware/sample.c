/* sample.c - see sample.h. */
#include "sample.h"

#include "board.h"
#include "config.h"

allan_t sample_engine;
sample_stats_t sample_stats;

/* The temperature's 40-bit sum: 32 bits and a byte for the carry. */
static inline __attribute__((always_inline)) void temp_add(uint16_t code)
{
#ifdef __AVR__
  uint32_t sum = sample_stats.temp_sum;
  uint8_t hi = sample_stats.temp_sum_hi;
  __asm__("add %A[s], %A[c]\n\tadc %B[s], %B[c]\n\tadc %C[s], __zero_reg__\n\t"
          "adc %D[s], __zero_reg__\n\tadc %[h], __zero_reg__"
          : [s] "+r"(sum), [h] "+r"(hi)
          : [c] "r"(code));
  sample_stats.temp_sum = sum;
  sample_stats.temp_sum_hi = hi;
#else
  if ((sample_stats.temp_sum += code) < code)
    sample_stats.temp_sum_hi++;
#endif
}

void sample_take(void)
{
  uint8_t i, counted;
  /* Codes are read one at a time from the ring: no copy on the stack of
   * the engine's deepest path. */
  BOARD_PROBE_SAMPLE_ON();
  /* A set the engine refuses (its 32-bit count is full) is lost like a
   * dropped one, and counted as such. */
  BOARD_PROBE_ALLAN_ON();
  counted = allan_begin(&sample_engine) == ALLAN_OK;
  BOARD_PROBE_ALLAN_OFF();
  if (!counted)
    adc_count_drop();
  for (i = 0; i < ADC_COLUMNS; i++) {
    uint16_t code = adc_oldest(i);
    if ((code == 0 || code == ALLAN_CODE_MAX) && sample_stats.clips[i] != 0xFFFFu)
      sample_stats.clips[i]++;
    if (i < ALLAN_CHANNELS) {
      if (counted) {
        BOARD_PROBE_ALLAN_ON();
        allan_channel(&sample_engine, i, code);
        BOARD_PROBE_ALLAN_OFF();
      }
    } else {
      temp_add(code);
      if (code < sample_stats.temp_min)
        sample_stats.temp_min = code;
      if (code > sample_stats.temp_max)
        sample_stats.temp_max = code;
    }
  }
  sample_stats.since_report++;
  adc_discard();
  BOARD_PROBE_SAMPLE_OFF();
}

uint8_t sample_settle(void)
{
  if (!allan_waiting(&sample_engine))
    return 0; /* the idle pass: no probe pulse, no call */
  BOARD_PROBE_ALLAN_ON();
  allan_settle_some(&sample_engine);
  BOARD_PROBE_ALLAN_OFF();
  return 1;
}

void sample_reset(void)
{
  uint8_t i;
  allan_reset(&sample_engine);
  for (i = 0; i < ADC_COLUMNS; i++)
    sample_stats.clips[i] = 0;
  adc_clear_drops();
}

void sample_interval_restart(void)
{
  sample_stats.since_report = 0;
  sample_stats.temp_sum = 0;
  sample_stats.temp_sum_hi = 0;
  sample_stats.temp_min = 0xFFFF;
  sample_stats.temp_max = 0;
}
