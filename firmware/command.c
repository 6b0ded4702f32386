/* command.c - see command.h. */
#include "command.h"

#include "pgm.h"

/* Kinds of argument a command takes. */
enum { ARG_NONE, ARG_OPT_NUM, ARG_NUM, ARG_MODE, ARG_RANGE };

/* Words, in the order of the CMD_* ids starting at CMD_REPORT, and the
 * argument each takes. */
static const char cmd_words[] PROGMEM =
  "report\0reset\0stop\0start\0rate\0status\0help\0interval\0mode\0range\0save\0load\0defaults\0";
static const uint8_t cmd_arg[] PROGMEM = {ARG_NONE, ARG_NONE, ARG_NONE, ARG_OPT_NUM, ARG_NUM,
                                          ARG_NONE, ARG_NONE, ARG_NUM, ARG_MODE, ARG_RANGE,
                                          ARG_NONE, ARG_NONE, ARG_NONE};
#define CMD_COUNT 13

/* Argument words, each list in the order of its MODE_* / RANGE_* values. */
static const char mode_words[] PROGMEM = "allan\0raw\0binary\0both\0";
static const char range_words[] PROGMEM = "1.5\0" "2\0" "4\0" "6\0";

static char lower(char c)
{
  return (c >= 'A' && c <= 'Z') ? (char)(c - 'A' + 'a') : c;
}

static uint8_t is_space(char c)
{
  return c == ' ' || c == '\t';
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

/* Index of the word p[0..len) in a list of NUL-separated flash words
 * (ended by an empty word), ignoring case; `count` when absent. */
static uint8_t find_word(const char *list, uint8_t count, const char *p, uint16_t len)
{
  uint8_t i;
  for (i = 0; i < count; i++) {
    uint16_t j = 0;
    while (j < len && pgm_read_byte(list + j) && lower(p[j]) == (char)pgm_read_byte(list + j))
      j++;
    if (j == len && !pgm_read_byte(list + j))
      return i;
    while (pgm_read_byte(list))
      list++;
    list++;
  }
  return count;
}

uint8_t command_parse(const char *line, command_t *out)
{
  const char *p = line;
  uint8_t id, kind;
  uint16_t len;

  out->id = CMD_NONE;
  out->has_arg = 0;
  out->arg = 0;
  while (is_space(*p))
    p++;
  if (!*p)
    return CMD_OK;

  len = word_len(p);
  id = find_word(cmd_words, CMD_COUNT, p, len);
  if (id == CMD_COUNT)
    return CMD_ERR_UNKNOWN;
  kind = pgm_read_byte(&cmd_arg[id]);
  p += len;
  while (is_space(*p))
    p++;

  if (*p) {
    len = word_len(p);
    if (kind == ARG_NONE) {
      return CMD_ERR_ARG;
    } else if (kind == ARG_MODE || kind == ARG_RANGE) {
      uint8_t v = kind == ARG_MODE ? find_word(mode_words, 4, p, len)
                                   : find_word(range_words, 4, p, len);
      if (v == 4)
        return CMD_ERR_ARG;
      out->arg = v;
    } else {
      uint32_t v = 0;
      uint16_t i;
      for (i = 0; i < len; i++) {
        uint8_t d = (uint8_t)(p[i] - '0');
        if (d > 9)
          return CMD_ERR_ARG;
        if (v > (0xFFFFFFFFul - d) / 10u)
          return CMD_ERR_ARG; /* does not fit 32 bits */
        v = v * 10u + d;
      }
      out->arg = v;
    }
    p += len;
    while (is_space(*p))
      p++;
    if (*p)
      return CMD_ERR_ARG; /* one argument at most */
    out->has_arg = 1;
  } else if (kind != ARG_NONE && kind != ARG_OPT_NUM) {
    return CMD_ERR_ARG;
  }
  out->id = (uint8_t)(CMD_REPORT + id);
  return CMD_OK;
}

uint8_t command_rate_ok(uint32_t hz)
{
  return hz == 50 || hz == 100 || hz == 200 || hz == 250 || hz == 500 || hz == 1000 || hz == 1250;
}

static const char *nth_word(const char *list, uint8_t n)
{
  while (n--) {
    while (pgm_read_byte(list))
      list++;
    list++;
  }
  return list;
}

const char *command_mode_name(uint8_t mode)
{
  return nth_word(mode_words, mode);
}

const char *command_range_name(uint8_t range)
{
  return nth_word(range_words, range);
}
