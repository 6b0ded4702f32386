/* command.c - see command.h. */
#include "command.h"

#include "pgm.h"

/* Words, in the order of the CMD_* ids starting at CMD_REPORT, and whether
 * each takes a number: 0 none, 1 optional, 2 required. */
static const char cmd_words[] PROGMEM = "report\0reset\0stop\0start\0rate\0status\0help\0";
static const uint8_t cmd_arg[] PROGMEM = {0, 0, 0, 1, 2, 0, 0};
#define CMD_COUNT 7

static char lower(char c)
{
  return (c >= 'A' && c <= 'Z') ? (char)(c - 'A' + 'a') : c;
}

static uint8_t is_space(char c)
{
  return c == ' ' || c == '\t';
}

uint8_t command_parse(const char *line, command_t *out)
{
  const char *w = cmd_words;
  const char *p;
  uint8_t id;

  out->id = CMD_NONE;
  out->has_arg = 0;
  out->arg = 0;
  while (is_space(*line))
    line++;
  if (!*line)
    return CMD_OK;

  for (id = 0; id < CMD_COUNT; id++) {
    /* Compare the first word of the line with this table word. */
    const char *q = w;
    p = line;
    while (pgm_read_byte(q) && lower(*p) == (char)pgm_read_byte(q)) {
      p++;
      q++;
    }
    if (!pgm_read_byte(q) && (!*p || is_space(*p)))
      break;
    while (pgm_read_byte(w))
      w++;
    w++;
  }
  if (id == CMD_COUNT)
    return CMD_ERR_UNKNOWN;

  while (is_space(*p))
    p++;
  if (*p) {
    uint32_t v = 0;
    if (!pgm_read_byte(&cmd_arg[id]))
      return CMD_ERR_ARG;
    if (*p < '0' || *p > '9')
      return CMD_ERR_ARG;
    while (*p >= '0' && *p <= '9') {
      uint8_t d = (uint8_t)(*p++ - '0');
      if (v > (0xFFFFFFFFul - d) / 10u)
        return CMD_ERR_ARG; /* does not fit 32 bits */
      v = v * 10u + d;
    }
    while (is_space(*p))
      p++;
    if (*p)
      return CMD_ERR_ARG;
    out->has_arg = 1;
    out->arg = v;
  } else if (pgm_read_byte(&cmd_arg[id]) == 2) {
    return CMD_ERR_ARG;
  }
  out->id = (uint8_t)(CMD_REPORT + id);
  return CMD_OK;
}

uint8_t command_rate_ok(uint32_t hz)
{
  return hz == 50 || hz == 100 || hz == 200 || hz == 250 || hz == 500 || hz == 1000;
}
