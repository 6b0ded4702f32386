/* command.c - see command.h. */
#include "command.h"

#include "pgm.h"
#include "vocab.h"

/* Words, in the order of the CMD_* ids starting at CMD_REPORT, and the
 * argument each takes. */
static const char cmd_words[] PROGMEM =
    "report\0reset\0stop\0start\0rate\0status\0help\0interval\0mode\0range\0save\0load\0defaults\0echo\0units";
static const uint8_t cmd_arg[] PROGMEM = {ARG_NONE, ARG_NONE, ARG_NONE,    ARG_COUNT, ARG_RATE,
                                          ARG_NONE, ARG_NONE, ARG_SECONDS, ARG_MODE,  ARG_RANGE,
                                          ARG_NONE, ARG_NONE, ARG_NONE,    ARG_ONOFF, ARG_UNITS};

const char *command_word(uint8_t id)
{
  return vocab_word(cmd_words, (uint8_t)(id - CMD_REPORT));
}

uint8_t command_arg_kind(uint8_t id)
{
  return pgm_read_byte(&cmd_arg[id - CMD_REPORT]);
}

static uint8_t is_space(char c)
{
  return c == ' ' || c == '\t';
}

/* p past any spaces and tabs. */
static __attribute__((noinline)) const char *skip_spaces(const char *p)
{
  while (is_space(*p))
    p++;
  return p;
}

/* Length of the word at p (up to a space, a tab or the end).  16 bits:
 * the parser takes any string, longer than the device's line buffer. */
static uint16_t word_len(const char *p)
{
  uint16_t n = 0;
  while (p[n] && !is_space(p[n]))
    n++;
  return n;
}

uint8_t command_parse(const char *line, command_t *out)
{
  const char *p = line;
  uint8_t id, kind;
  uint16_t len;

  out->id = CMD_NONE;
  out->has_arg = 0;
  out->arg = 0;
  p = skip_spaces(p);
  if (!*p)
    return CMD_OK;

  len = word_len(p);
  id = vocab_find(cmd_words, CMD_COUNT, p, len);
  if (id == CMD_COUNT)
    return CMD_ERR_UNKNOWN;
  kind = pgm_read_byte(&cmd_arg[id]);
  out->id = (uint8_t)(CMD_REPORT + id); /* named in an argument error */
  p = skip_spaces(p + len);

  if (*p) {
    len = word_len(p);
    if (kind == ARG_NONE) {
      return CMD_ERR_ARG;
    } else if (kind >= ARG_MODE) {
      uint8_t count = kind == ARG_MODE ? VOCAB_MODES : kind == ARG_RANGE ? VOCAB_RANGES : 2;
      uint8_t v = vocab_find(kind == ARG_MODE  ? vocab_modes :
                             kind == ARG_RANGE ? vocab_ranges :
                             kind == ARG_ONOFF ? vocab_onoff :
                                                 vocab_units,
                             count, p, len);
      if (v == count)
        return CMD_ERR_ARG;
      out->arg = v;
    } else {
      uint32_t v = 0;
      uint16_t i;
      for (i = 0; i < len; i++) {
        uint8_t d = (uint8_t)(p[i] - '0');
        if (d > 9)
          return CMD_ERR_ARG;
        if (v > 429496729ul || (v == 429496729ul && d > 5))
          return CMD_ERR_ARG; /* does not fit 32 bits: above 4294967295 */
        v = v * 10u + d;
      }
      out->arg = v;
    }
    if (*skip_spaces(p + len))
      return CMD_ERR_ARG; /* one argument at most */
    out->has_arg = 1;
  } else if (kind > ARG_COUNT && kind < ARG_ONOFF) {
    return CMD_ERR_ARG;
  }
  return CMD_OK;
}
