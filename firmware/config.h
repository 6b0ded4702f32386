/*
 * config.h - compile-time options of the imu-allan firmware.
 *
 * Everything a user may want to change lives here (or on the make command
 * line as -DNAME=value); the checks below refuse combinations that would be
 * silently wrong.  Pins and MCU specifics are in board.h, not here.
 */
#ifndef CONFIG_H
#define CONFIG_H

/* Sensor channels the Allan engine follows: accel X Y Z, gyro X Y Z.
 * Temperature is sampled too but only summarised (mean/min/max). */
#define ALLAN_CHANNELS 6

/* Octave levels: cluster sizes m = 1, 2, 4, ... 2^(ALLAN_LEVELS-1).
 * 15 levels (m up to 16384, 164 s at 100 Hz) is what fits the ATmega168's
 * 1 KB SRAM beside the rings and the stack; the ATmega328P has room for 20
 * (m up to 524288, 1.5 h at 100 Hz). */
#ifndef ALLAN_LEVELS
#  if defined(__AVR_ATmega328P__) || defined(__AVR_ATmega328__)
#    define ALLAN_LEVELS 20
#  else
#    define ALLAN_LEVELS 15
#  endif
#endif

#if ALLAN_LEVELS < 8
#  error "ALLAN_LEVELS must be at least 8 (m up to 128)"
#endif
/* Cluster sums are kept modulo 2^24; at level 23 and above even a range of a
 * single code could break the 2^23 difference bound, so such levels could
 * never be exact.  The sample counter is 32 bits, which caps levels anyway. */
#if ALLAN_LEVELS > 23
#  error "ALLAN_LEVELS above 23 cannot be exact with 24-bit cluster sums"
#endif

/* Largest ADC code the engine accepts (10-bit converter). */
#define ALLAN_CODE_MAX 1023u

#endif /* CONFIG_H */
