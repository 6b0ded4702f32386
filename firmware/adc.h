/*
 * adc.h - the 7-channel ADC scan (accel X Y Z, gyro X Y Z, temperature).
 */
#ifndef ADC_H
#define ADC_H

#include <stdint.h>

#define ADC_COLUMNS 7

/* Reference, prescaler, digital input buffers off on the used pins. */
void adc_init(void);

/* Convert all columns in row order, blocking until done. */
void adc_scan(uint16_t code[ADC_COLUMNS]);

#endif /* ADC_H */
