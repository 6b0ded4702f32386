/*
 * vocab.h - the protocol's vocabulary (docs/protocol.md), one home for each
 * word and limit the device and its host share: version, output modes,
 * accelerometer ranges, sample rates, the report interval's limit, and the
 * name tables printed in headers, replies and status lines.  Pure: builds
 * on the AVR (tables in flash) and natively (tests, fuzzers).
 */
#ifndef VOCAB_H
#define VOCAB_H

#include <stdint.h>

/* `proto=` of the boot line and every report header. */
#define PROTO_VERSION 1

/* Output modes; the names are vocab_modes, in this order. */
#define MODE_ALLAN 0
#define MODE_RAW 1
#define MODE_BINARY 2
#define MODE_BOTH 3
#define VOCAB_MODES 4

/* Accelerometer ranges: the MMA7260Q's g-select code GS2 GS1 (1.5, 2, 4,
 * 6 g); the names are vocab_ranges, in this order. */
#define RANGE_1G5 0
#define RANGE_2G 1
#define RANGE_4G 2
#define RANGE_6G 3
#define VOCAB_RANGES 4

/* The supported sample rates in Hz, ascending: the one list (an X-macro:
 * X(a, hz) for each rate, `a` passed through), from which come
 * VOCAB_RATE_OK (config.h checks its default with the preprocessor),
 * vocab_rates[] (the run-time test, help and errors) and the link
 * budget's table (link.c).
 * 1500 is the highest the 7-column ADC scan (0.64 ms) fits; its Timer1
 * period is exact on average only, dithered by one CPU cycle (adc.c,
 * docs/firmware.md). */
#define VOCAB_RATES(X, a) X(a, 50) X(a, 100) X(a, 200) X(a, 250) X(a, 500) X(a, 1000) X(a, 1250) X(a, 1500)
#define VOCAB_RATE_EQ_(hz, r) || (hz) == (r)
#define VOCAB_RATE_OK(hz) (0 VOCAB_RATES(VOCAB_RATE_EQ_, hz))
#define VOCAB_RATE_ONE_(a, r) +1
#define VOCAB_RATE_COUNT (0 VOCAB_RATES(VOCAB_RATE_ONE_, 0))

/* Longest report interval in seconds (`interval`, REPORT, the EEPROM). */
#define VOCAB_INTERVAL_MAX_S 3600

/* Where the settings in force came from (`cfg=`): vocab_sources.
 * CFG_INFEASIBLE: a saved record whose rate/mode pair the link cannot
 * carry (checked like the `rate` and `mode` commands); defaults in force. */
enum { CFG_SAVED, CFG_BLANK, CFG_CORRUPT, CFG_DEFAULTS, CFG_INFEASIBLE };

/* Name tables: NUL-separated words in flash, in the order of the values
 * above.  vocab_causes follows the MCUSR bits PORF EXTRF BORF WDRF. */
extern const char vocab_modes[];
extern const char vocab_ranges[];
extern const char vocab_sources[];
extern const char vocab_causes[];
extern const char vocab_onoff[]; /* "off", "on": 0, 1 */
extern const char vocab_units[]; /* "phys", "counts": settings.counts 0, 1 */
/* Channel names, two letters each, no separator: "axayazgxgygz". */
extern const char vocab_channels[];

/* The n-th word of a word list (flash pointer). */
const char *vocab_word(const char *list, uint8_t n);

/* Index of the word p[0..len) among the first `count` words of a list,
 * ignoring ASCII case; `count` when absent. */
uint8_t vocab_find(const char *list, uint8_t count, const char *p, uint16_t len);

/* The supported rates (flash), VOCAB_RATE_COUNT of them. */
extern const uint16_t vocab_rates[];

/* Index of hz in vocab_rates, or VOCAB_RATE_COUNT when it is not one. */
uint8_t vocab_rate_index(uint32_t hz);

/* 1 when hz is a supported sample rate. */
#define vocab_rate_ok(hz) (vocab_rate_index(hz) < VOCAB_RATE_COUNT)

#endif /* VOCAB_H */
