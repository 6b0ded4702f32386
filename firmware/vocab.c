/* vocab.c - see vocab.h. */
#include "vocab.h"

#include "pgm.h"

const char vocab_modes[] PROGMEM = "allan\0raw\0binary\0both";
const char vocab_ranges[] PROGMEM = "1.5\0"
                                    "2\0"
                                    "4\0"
                                    "6";
const char vocab_sources[] PROGMEM = "saved\0blank\0corrupt\0defaults\0infeasible";
const char vocab_causes[] PROGMEM = "por\0ext\0bor\0wdt";
const char vocab_onoff[] PROGMEM = "off\0on";
const char vocab_units[] PROGMEM = "phys\0counts";
const char vocab_channels[] PROGMEM = "axayazgxgygz";

static char lower(char c)
{
  return (c >= 'A' && c <= 'Z') ? (char)(c - 'A' + 'a') : c;
}

const char *vocab_word(const char *list, uint8_t n)
{
  while (n--) {
    while (pgm_read_byte(list))
      list++;
    list++;
  }
  return list;
}

uint8_t vocab_find(const char *list, uint8_t count, const char *p, uint16_t len)
{
  uint8_t i;
  for (i = 0; i < count; i++, list = vocab_word(list, 1)) {
    uint16_t j = 0;
    while (j < len && pgm_read_byte(list + j) && lower(p[j]) == (char)pgm_read_byte(list + j))
      j++;
    if (j == len && !pgm_read_byte(list + j))
      return i;
  }
  return count;
}

#define RATE_ITEM(a, hz) hz,
const uint16_t vocab_rates[] PROGMEM = {VOCAB_RATES(RATE_ITEM, 0)};

uint8_t vocab_rate_index(uint32_t hz)
{
  uint8_t i;
  for (i = 0; i < VOCAB_RATE_COUNT && pgm_read_word(&vocab_rates[i]) != hz; i++)
    ;
  return i;
}
