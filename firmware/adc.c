/*
 * adc.c - polled 7-channel scan.  One conversion per column, in the order
 * of board.h's mux list.
 */
#include "adc.h"
#include "board.h"

static const uint8_t adc_mux[ADC_COLUMNS] = BOARD_ADC_MUX_LIST;

void adc_init(void)
{
  ADMUX = BOARD_ADMUX_REF;
  ADCSRA = (1 << ADEN) | BOARD_ADPS;
  DIDR0 = 0x3F; /* ADC0..5 are analog only: no digital input buffers */
}

void adc_scan(uint16_t code[ADC_COLUMNS])
{
  uint8_t i;
  for (i = 0; i < ADC_COLUMNS; i++) {
    ADMUX = BOARD_ADMUX_REF | adc_mux[i];
    ADCSRA |= (1 << ADSC);
    while (ADCSRA & (1 << ADSC))
      ;
    code[i] = ADC;
  }
}
