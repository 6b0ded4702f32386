/*
 * sim_adc.h - the ADC: the i-th conversion of mux channel j reads column j
 * of input row i.
 */
#ifndef SIM_ADC_H
#define SIM_ADC_H

#include <stdint.h>

#include "harness.h"

void adc_connect(harness_t *h);                 /* hooks the ADC's trigger */
uint64_t adc_rows_consumed(const harness_t *h); /* whole rows converted */

#endif /* SIM_ADC_H */
