/*
 * adc.h - timed sampling: Timer1 ticks at the sample rate, each tick starts
 * a scan of the 7 columns (accel X Y Z, gyro X Y Z, temperature) driven by
 * the ADC interrupt, and a finished scan lands in a small ring that the main
 * loop drains.  A scan that finds no room, or a tick that finds the previous
 * scan unfinished, counts as a dropped sample set.
 */
#ifndef ADC_H
#define ADC_H

#include <stdint.h>

#define ADC_COLUMNS 7

void adc_init(void);

/* Sample rate in Hz, one of vocab_rates (vocab.h); call while stopped.
 * adc_rate() reads it back from the timer (no copy kept). */
void adc_set_rate(uint16_t hz);
uint16_t adc_rate(void);

/* Start ticking. With limited, take exactly `count` more scans, then stop. */
void adc_start(uint8_t limited, uint32_t count);

/* Scans a limited start still has to take, or ADC_UNLIMITED. */
#define ADC_UNLIMITED 0xFFFFFFFFul
uint32_t adc_remaining(void);

/* Limit the running tick to `total` sets counting those already waiting in
 * the ring (a new run keeps a `start <count>`). */
void adc_limit(uint32_t total);

/* Stop ticking and wait for an unfinished scan to land in the ring. */
void adc_stop(void);

/* 1 while the tick runs, or a scan it started has not landed yet (a
 * `start <count>` stops the tick as its last scan begins). */
uint8_t adc_running(void);

/* The oldest finished scan, left in the ring; 0 when the ring is empty. */
uint8_t adc_peek(uint16_t code[ADC_COLUMNS]);

/* Code of column col of the oldest scan (only while adc_pending()). */
uint16_t adc_oldest(uint8_t col);

/* The same scan as packed in the ring (and in binary frames): low 8 bits of
 * each code, then a little-endian word holding code i's top 2 bits at bits
 * 2i..2i+1.  0 when the ring is empty. */
#define ADC_PACKED_BYTES 9
uint8_t adc_peek_packed(uint8_t out[ADC_PACKED_BYTES]);

/* Remove the oldest scan; adc_flush() removes them all (call while stopped). */
void adc_discard(void);
void adc_flush(void);

/* Finished scans waiting in the ring. */
uint8_t adc_pending(void);

/* Dropped sample sets since the last adc_clear_drops(). */
uint32_t adc_drops(void);
void adc_clear_drops(void);

/* Count one more dropped set (also used by the main loop). */
void adc_count_drop(void);

#endif /* ADC_H */
