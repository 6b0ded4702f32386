/*
 * main.c - imu-allan firmware: scan the sensors and feed the Allan engine.
 */
#include <stdint.h>

#include "adc.h"
#include "allan.h"

static allan_t allan;

int main(void)
{
  uint16_t code[ADC_COLUMNS];

  adc_init();
  allan_reset(&allan);
  for (;;) {
    adc_scan(code);
    allan_push(&allan, code); /* the first six columns are the sensors */
  }
}
