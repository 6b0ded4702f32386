/*
 * config.h - compile-time options of the imu-allan firmware.
 *
 * Everything a user may want to change lives here (or on the make command
 * line as -DNAME=value); the checks below refuse combinations that would be
 * silently wrong.  Pins and MCU specifics are in board.h, not here.
 */
#ifndef CONFIG_H
#define CONFIG_H

#include "vocab.h"

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

/* The release version: the VERSION file at the repository root, passed by
 * the Makefile as -DFW_VERSION; native test builds without it say "dev". */
#ifndef FW_VERSION
#  define FW_VERSION "dev"
#endif

/* MCU name for the reports, from the compiler's device macro. */
#define CONFIG_STR2(x) #x
#define CONFIG_STR(x) CONFIG_STR2(x)
#ifdef __AVR_DEVICE_NAME__
#  define FW_MCU_NAME CONFIG_STR(__AVR_DEVICE_NAME__)
#else
#  define FW_MCU_NAME "host"
#endif

/* Default sample rate (Hz) at power-up: 50, 100, 200, 250, 500, 1000,
 * 1250 or 1500 (the highest the 7-column ADC scan, 0.64 ms, fits; its
 * Timer1 period is dithered by one CPU cycle: see docs/firmware.md). */
#ifndef FS_DEFAULT
#  define FS_DEFAULT 100
#endif
#if !VOCAB_RATE_OK(FS_DEFAULT)
#  error "FS_DEFAULT must be one of 50, 100, 200, 250, 500, 1000, 1250, 1500"
#endif

/* Seconds of sampling between periodic reports (0: only on request). */
#ifndef REPORT
#  define REPORT 60
#endif
#if REPORT < 0 || REPORT > VOCAB_INTERVAL_MAX_S
#  error "REPORT must be 0..VOCAB_INTERVAL_MAX_S seconds"
#endif

/* Accumulator width.  Levels from ALLAN_ACC48_FROM up get 48 bits, those
 * below 40 bits.  Low levels are dominated by white noise, whose
 * accumulator grows like 2 n sigma^2 at every level: 40 bits last 2^40 /
 * (2 sigma^2) samples, i.e. 2 years at 1 kHz for sigma = 3 codes.  Drift and
 * random walk grow like n m^2, so long clusters get 48 bits.  The ATmega168
 * needs the 5 bytes this saves to keep its stack margin; the ATmega328P has
 * room for 48 bits everywhere.  A full accumulator saturates and is
 * flagged, never wraps. */
#ifndef ALLAN_ACC48_FROM
#  if defined(__AVR_ATmega328P__) || defined(__AVR_ATmega328__)
#    define ALLAN_ACC48_FROM 0
#  else
#    define ALLAN_ACC48_FROM 11
#  endif
#endif
#if ALLAN_ACC48_FROM < 0 || ALLAN_ACC48_FROM >= ALLAN_LEVELS
#  error "ALLAN_ACC48_FROM must be 0..ALLAN_LEVELS-1 (the top level keeps 48 bits)"
#endif

/* Output mode and accelerometer range at power-up (vocab.h's MODE_*,
 * RANGE_*), unless the EEPROM holds saved settings. */
#ifndef MODE_DEFAULT
#  define MODE_DEFAULT MODE_ALLAN
#endif
#ifndef RANGE_DEFAULT
#  define RANGE_DEFAULT RANGE_1G5
#endif
#if MODE_DEFAULT < MODE_ALLAN || MODE_DEFAULT > MODE_BOTH
#  error "MODE_DEFAULT must be MODE_ALLAN, MODE_RAW, MODE_BINARY or MODE_BOTH"
#endif
#if RANGE_DEFAULT < RANGE_1G5 || RANGE_DEFAULT > RANGE_6G
#  error "RANGE_DEFAULT must be RANGE_1G5 .. RANGE_6G"
#endif

/* Output steps: every producer (replies, reports, the sample stream) writes
 * at most this many bytes a step, each only once the TX ring has room for a
 * whole one; the ring holds one step (UART_STEP_MAX + 1 bytes of SRAM).
 * Longer steps mean fewer turns of the output scheduler but a longer ring,
 * and a longer wait for a raw row behind a step (link.h); the longest piece
 * that may not be split (the header's `1023.0:1023:1023`, a raw row's half,
 * a status field) must fit. */
#ifndef UART_STEP_MAX
#  define UART_STEP_MAX 20
#endif

/* Receive ring, bytes, a power of two: it holds what arrives while the
 * main loop is busy with one sample set or one piece of the engine's
 * waiting work (8 bytes: 0.69 ms at 115200 baud, against at most 0.4 ms
 * for either); every byte of it is the stack's. */
#ifndef UART_RX_SIZE
#  define UART_RX_SIZE 8
#endif
#if UART_RX_SIZE & (UART_RX_SIZE - 1)
#  error "UART_RX_SIZE must be a power of two"
#endif

/* Longest command line accepted, without its end of line and its check:
 * the longest command, "start 4294967295".  The console keeps the line in
 * SRAM (COMMAND_LINE_MAX + 1 bytes); a longer line is refused (error:3). */
#ifndef COMMAND_LINE_MAX
#  define COMMAND_LINE_MAX 16
#endif

/* Characters of an unknown command's first word quoted back in its error
 * reply; the reply keeps a copy (the line's buffer takes the next line at
 * once), so each is a byte of SRAM. */
#ifndef REPLY_QUOTE_MAX
#  define REPLY_QUOTE_MAX 6
#endif

/* Levels a T line's B (the flicker floor, the least deviation) may come
 * from: those with at least this many pairs, whose deviation is known to
 * within about 25 % (100 / sqrt(2 pairs)); fewer would make the minimum a
 * matter of chance.  T lines come only when level 0 has that many. */
#ifndef TERMS_B_PAIRS
#  define TERMS_B_PAIRS 8u
#endif

/* Lagging channels: in a set that completes ALLAN_LAG_DEPTH levels or more
 * (one set in 2^(ALLAN_LAG_DEPTH-1)), channels ALLAN_LAG_FROM and up do
 * their levels 2 and up after the set (the main loop's sample_settle, or
 * the next set's start), so that the deepest cascade is split in two:
 * the worst set's cycles at 1500 Hz (docs/allan-engine.md, "Spreading the
 * cascade").  It costs no RAM: the parked code waits in bits no sum uses. */
#ifndef ALLAN_LAG_FROM
#  define ALLAN_LAG_FROM 2u
#endif
#ifndef ALLAN_LAG_DEPTH
#  define ALLAN_LAG_DEPTH 4u
#endif

/* The default mode must keep up with the link at the default rate:
 * checked at compile time in link.c (link.h includes this file). */

/* Silence after which an open command line (bytes without CR or LF) is
 * discarded with one `error:7` reply (docs/protocol.md): a stray byte on a
 * radio link, or a line whose end was lost, must never glue itself onto
 * the next command, and a terminal must not be left with a line it cannot
 * see.  A host sends a whole line within milliseconds; a person types a
 * command with shorter pauses than this.  At most 6500 ms (the console's
 * clock counts up to 255 ticks of 26 ms at 10 MHz: clock.h). */
#ifndef CONSOLE_TIMEOUT_MS
#  define CONSOLE_TIMEOUT_MS 2000
#endif
#if CONSOLE_TIMEOUT_MS < 100 || CONSOLE_TIMEOUT_MS > 6500
#  error "CONSOLE_TIMEOUT_MS must be 100..6500"
#endif

/* Largest ADC code the engine accepts (10-bit converter). */
#define ALLAN_CODE_MAX 1023u

#endif /* CONFIG_H */
