/*
 * settings.c - see settings.h.  EEPROM record at address 0:
 *   byte 0      SETTINGS_VERSION
 *   bytes 1..7  settings_t (rate, interval, mode, range, echo and units bits)
 *   bytes 8..9  CRC-16/MODBUS (crc.h), high byte first, of bytes 0..7
 * (version 1 had no echo byte: it reads as corrupt, the defaults apply.
 * `units` came later as bit 1 of the echo byte, 0 meaning physical units,
 * the default: a record saved before it loads as it was, in phys.)
 * A blank EEPROM reads 0xFF everywhere.
 */
#include "settings.h"

#include <avr/eeprom.h>

#include "config.h"
#include "crc.h"
#include "link.h"
#include "vocab.h"

#define SETTINGS_VERSION 2
#define RECORD_BYTES (1u + sizeof(settings_t) + 2u)

settings_t settings;

/* Record bytes still to write; 0: idle (in .bss: no .data to copy at boot). */
static uint8_t save_left;

/* Byte i of the record for the current settings (crc: of bytes 0..7). */
static uint8_t record_byte(uint8_t i, uint16_t crc)
{
  if (i == 0)
    return SETTINGS_VERSION;
  if (i <= sizeof(settings_t))
    return ((const uint8_t *)&settings)[i - 1];
  return i == sizeof(settings_t) + 1u ? (uint8_t)(crc >> 8) : (uint8_t)crc;
}

/* The CRC of a record's first bytes: its version and settings s. */
static uint16_t record_crc(uint8_t version, const settings_t *s)
{
  uint16_t crc = crc16_modbus_update(CRC16_MODBUS_INIT, version);
  uint8_t i;
  for (i = 0; i < sizeof(settings_t); i++)
    crc = crc16_modbus_update(crc, ((const uint8_t *)s)[i]);
  return crc;
}

static uint8_t valid(const settings_t *s)
{
  return vocab_rate_ok(s->rate_hz) && s->interval_s <= VOCAB_INTERVAL_MAX_S && s->mode < VOCAB_MODES &&
         s->range < VOCAB_RANGES &&
         !(((const uint8_t *)s)[sizeof(settings_t) - 1] & 0xFCu); /* source (CFG_SAVED) and unused: 0 */
}

void settings_defaults(void)
{
  settings.rate_hz = FS_DEFAULT;
  settings.interval_s = REPORT;
  settings.mode = MODE_DEFAULT;
  settings.range = RANGE_DEFAULT;
  settings.echo = 1;
  settings.counts = 0;
  settings_source = CFG_DEFAULTS;
}

uint8_t settings_load(void)
{
  struct {
    uint8_t version;
    settings_t s;
    uint8_t crc_hi, crc_lo;
  } __attribute__((packed)) rec; /* the record as laid out above */
  _Static_assert(sizeof rec == RECORD_BYTES, "the record: version, settings, CRC");
  const uint8_t *b = (const uint8_t *)&rec;
  uint8_t i, all = 0xFF, source;
  uint16_t crc;
  eeprom_read_block(&rec, (const void *)0, RECORD_BYTES);
  for (i = 0; i < RECORD_BYTES; i++)
    all &= b[i];
  crc = record_crc(rec.version, &rec.s);
  if (all == 0xFF) {
    source = CFG_BLANK;
  } else if (rec.version != SETTINGS_VERSION || rec.crc_hi != (uint8_t)(crc >> 8) ||
             rec.crc_lo != (uint8_t)crc || !valid(&rec.s)) {
    source = CFG_CORRUPT;
  } else if (!link_fits_here(rec.s.mode, rec.s.rate_hz)) {
    source = CFG_INFEASIBLE; /* refused like `rate` and `mode` would be */
  } else {
    settings = rec.s; /* source: CFG_SAVED, as valid() checked */
    return CFG_SAVED;
  }
  settings_defaults();
  settings_source = source;
  return source;
}

void settings_save(void)
{
  /* The record holds source 0, CFG_SAVED: what the settings are from
   * now on (`cfg=` says so while the bytes are being written). */
  settings_source = CFG_SAVED;
  save_left = RECORD_BYTES;
}

uint8_t settings_saving(void)
{
  return save_left != 0;
}

uint8_t settings_poll(void)
{
  uint8_t pos = (uint8_t)(RECORD_BYTES - save_left);
  if (!save_left || !eeprom_is_ready())
    return 0;
  /* update: a byte already holding its value is not rewritten (wear). */
  /* The CRC is worked out again for each byte rather than kept: RAM is
   * scarcer than the few hundred cycles this costs. */
  eeprom_update_byte(
      (uint8_t *)(uintptr_t)pos,
      record_byte(pos, pos > sizeof(settings_t) ? record_crc(SETTINGS_VERSION, &settings) : 0));
  return --save_left == 0;
}
