/*
 * board.h - everything specific to the thesis board and its MCU: ADC pin
 * map, reference, ADC clock, MMA7260Q g-select pins.  Change this file (and
 * only this file) for another board.
 */
#ifndef BOARD_H
#define BOARD_H

#include <avr/io.h>

#ifndef F_CPU
#  error "F_CPU must be given (the Makefile passes the board's 10 MHz crystal)"
#endif

/* ADC multiplexer channel of each column of a thesis row, in row order:
 * accel X Y Z, gyro X Y Z, temperature (adc.h's ADC_COLUMNS of them). */
#define BOARD_ADC_ACC_X 0
#define BOARD_ADC_ACC_Y 1
#define BOARD_ADC_ACC_Z 2
#define BOARD_ADC_GYR_X 3
#define BOARD_ADC_GYR_Y 4
#define BOARD_ADC_GYR_Z 5
#define BOARD_ADC_TEMP 6
#define BOARD_ADC_MUX_LIST                                                                                   \
  {                                                                                                          \
    BOARD_ADC_ACC_X, BOARD_ADC_ACC_Y, BOARD_ADC_ACC_Z, BOARD_ADC_GYR_X, BOARD_ADC_GYR_Y, BOARD_ADC_GYR_Z,    \
        BOARD_ADC_TEMP                                                                                       \
  }

/* Reference: AVCC, the board's regulated 3.3 V (the thesis' Vref; the
 * host converts codes to volts, the firmware never needs the value). */
#define BOARD_ADMUX_REF (1 << REFS0)

/* ADC clock must be 50..200 kHz for full 10-bit accuracy: pick the
 * smallest prescaler that brings F_CPU under 200 kHz. */
#if F_CPU / 2 <= 200000UL
#  define BOARD_ADC_PRESCALER 2
#  define BOARD_ADPS ((1 << ADPS0))
#elif F_CPU / 4 <= 200000UL
#  define BOARD_ADC_PRESCALER 4
#  define BOARD_ADPS ((1 << ADPS1))
#elif F_CPU / 8 <= 200000UL
#  define BOARD_ADC_PRESCALER 8
#  define BOARD_ADPS ((1 << ADPS1) | (1 << ADPS0))
#elif F_CPU / 16 <= 200000UL
#  define BOARD_ADC_PRESCALER 16
#  define BOARD_ADPS ((1 << ADPS2))
#elif F_CPU / 32 <= 200000UL
#  define BOARD_ADC_PRESCALER 32
#  define BOARD_ADPS ((1 << ADPS2) | (1 << ADPS0))
#elif F_CPU / 64 <= 200000UL
#  define BOARD_ADC_PRESCALER 64
#  define BOARD_ADPS ((1 << ADPS2) | (1 << ADPS1))
#else
#  define BOARD_ADC_PRESCALER 128
#  define BOARD_ADPS ((1 << ADPS2) | (1 << ADPS1) | (1 << ADPS0))
#endif
#if F_CPU / BOARD_ADC_PRESCALER < 50000UL || F_CPU / BOARD_ADC_PRESCALER > 200000UL
#  error "no ADC prescaler puts the ADC clock within 50..200 kHz at this F_CPU"
#endif

/* A byte of state in an I/O register rather than in SRAM, whose every
 * byte is the stack's margin: GPIOR2, a general-purpose register nothing
 * else uses (GPIOR0 holds the flags below, GPIOR1 clock.c's silence
 * count).  in/out reach it in one word where lds/sts take two: it holds
 * the output scheduler's step, read and written on every step. */
#define BOARD_SPARE_REG GPIOR2

/* Flags in GPIOR0, the one general-purpose I/O register that sbi, cbi,
 * sbis and sbic reach: a flag costs no SRAM and one instruction to set,
 * clear or test, where a byte of its own costs three.  The Timer1
 * interrupt rewrites the register (the dither phase), so outside
 * interrupts a bit is changed only by sbi or cbi (one instruction: no
 * interrupt comes between its read and its write) or with interrupts
 * off.  Bits 0..1: adc.c's 1500 Hz dither phase; the others one flag each. */
#define BOARD_FLAGS GPIOR0
#define BOARD_FLAG_DITHER 0x03u   /* adc.c: the dither phase 3, 2, 1; 0: no dither */
#define BOARD_FLAG_SCANNING 0x04u /* adc.c: a scan runs */
#define BOARD_FLAG_LIMITED 0x08u  /* adc.c: `start <count>` counts scans */
#define BOARD_FLAG_SET_DONE 0x10u /* stream.c: the oldest set's row or frame is written */
#define BOARD_FLAG_COUNTS 0x20u   /* report.c: the report in progress is in counts */
#define BOARD_FLAG_BOUND 0x40u    /* proto.c: the line being written is bound */
#define BOARD_FLAG_INTERVAL 0x80u /* report.c to loop.c: a header has written its interval's temperature */

/* MMA7260Q g-select: GS1 on PD6, GS2 on PD7 (00=1.5g 01=2g 10=4g 11=6g). */
#define BOARD_GSEL_DDR DDRD
#define BOARD_GSEL_PORT PORTD
#define BOARD_GSEL1_BIT PD6
#define BOARD_GSEL2_BIT PD7

/* Probe outputs for timing measurements (simulator or oscilloscope):
 * PB0 is high while the main loop handles one sample set, PB2 while the
 * Allan engine works on it, PB1 while the ADC interrupt runs.  Set
 * BOARD_PROBES to 0 to leave the pins alone. */
#ifndef BOARD_PROBES
#  define BOARD_PROBES 1
#endif
#if BOARD_PROBES
#  define BOARD_PROBE_INIT() (DDRB |= (1 << PB0) | (1 << PB1) | (1 << PB2))
#  define BOARD_PROBE_ALLAN_ON() (PORTB |= (1 << PB2))
#  define BOARD_PROBE_ALLAN_OFF() (PORTB &= (uint8_t) ~(1 << PB2))
#  define BOARD_PROBE_SAMPLE_ON() (PORTB |= (1 << PB0))
#  define BOARD_PROBE_SAMPLE_OFF() (PORTB &= (uint8_t) ~(1 << PB0))
#  define BOARD_PROBE_ISR_ON() (PORTB |= (1 << PB1))
#  define BOARD_PROBE_ISR_OFF() (PORTB &= (uint8_t) ~(1 << PB1))
#else
#  define BOARD_PROBE_INIT() ((void)0)
#  define BOARD_PROBE_ALLAN_ON() ((void)0)
#  define BOARD_PROBE_ALLAN_OFF() ((void)0)
#  define BOARD_PROBE_SAMPLE_ON() ((void)0)
#  define BOARD_PROBE_SAMPLE_OFF() ((void)0)
#  define BOARD_PROBE_ISR_ON() ((void)0)
#  define BOARD_PROBE_ISR_OFF() ((void)0)
#endif

/* Timer1 prescaler 8: every supported rate divides F_CPU/8 exactly at 10 MHz. */
#define BOARD_TIMER1_PRESCALER 8
#define BOARD_TIMER1_CS (1 << CS11)

#endif /* BOARD_H */
