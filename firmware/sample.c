/* sample.c - see sample.h. */
#include "sample.h"

#include "board.h"
#include "config.h"

#define COL_TEMP 6

allan_t sample_engine;
sample_stats_t sample_stats;

void sample_pump(void)
{
  uint16_t code[ADC_COLUMNS];
  while (adc_pop(code)) {
    uint8_t i;
    BOARD_PROBE_SAMPLE_ON();
    for (i = 0; i < ADC_COLUMNS; i++)
      if ((code[i] == 0 || code[i] == ALLAN_CODE_MAX) && sample_stats.clips[i] != 0xFFFFu)
        sample_stats.clips[i]++;
    sample_stats.temp_sum += code[COL_TEMP];
    if (code[COL_TEMP] < sample_stats.temp_min)
      sample_stats.temp_min = code[COL_TEMP];
    if (code[COL_TEMP] > sample_stats.temp_max)
      sample_stats.temp_max = code[COL_TEMP];
    sample_stats.since_report++;
    /* Columns 0..5 are the sensors.  A set the engine refuses (its 32-bit
     * count is full) is lost like a dropped one, and counted as such. */
    if (allan_push(&sample_engine, code) != ALLAN_OK)
      adc_count_drop();
    BOARD_PROBE_SAMPLE_OFF();
  }
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
  sample_stats.temp_min = 0xFFFF;
  sample_stats.temp_max = 0;
}
