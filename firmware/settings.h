/*
 * settings.h - the user's settings (rate, report interval, output mode,
 * accelerometer range, echo, units) and their copy in EEPROM: a versioned record with a
 * CRC-16, written only by `save`, one byte per main-loop pass so that
 * sampling never waits on the EEPROM.
 */
#ifndef SETTINGS_H
#define SETTINGS_H

#include <stdint.h>

#include "vocab.h" /* MODE_*, RANGE_*, CFG_* */

typedef struct {
  uint16_t rate_hz;
  uint16_t interval_s; /* 0: reports only on request */
  uint8_t mode;        /* MODE_* */
  uint8_t range;       /* RANGE_* */
  /* One byte, as in version 2 records before `units` (whose echo byte
   * was 0 or 1: counts 0, physical units, for them). */
  uint8_t echo : 1;   /* 1: typed characters are echoed (console.h) */
  uint8_t counts : 1; /* 1: `units counts`, the summary in ADC counts; 0: physical units */
  /* CFG_*: where the settings came from (`cfg=`).  Not a setting: it
   * lives in bits the record leaves 0 (so a record holds CFG_SAVED, 0,
   * which is what the settings it holds are once loaded), where it costs
   * no SRAM. */
  uint8_t source : 3;
  uint8_t unused : 3;                 /* 0 in a valid record */
} __attribute__((packed)) settings_t; /* the EEPROM record holds it byte for byte, on the AVR and natively */
#if CFG_SAVED != 0
#  error "a record's source bits are 0: CFG_SAVED must be 0"
#endif

extern settings_t settings;
#define settings_source (settings.source)

/* The built-in settings (config.h); source becomes CFG_DEFAULTS. */
void settings_defaults(void);

/* Read the EEPROM record; a blank, invalid or infeasible one gives the
 * defaults.  Returns (and records) CFG_SAVED, CFG_BLANK, CFG_CORRUPT or
 * CFG_INFEASIBLE. */
uint8_t settings_load(void);

/* Start writing the settings to EEPROM; settings_poll() finishes the job. */
void settings_save(void);

/* Write the next byte if the EEPROM is ready; returns 1 when a save has
 * just completed. */
uint8_t settings_poll(void);

/* 1 while a save is in progress. */
uint8_t settings_saving(void);

#endif /* SETTINGS_H */
