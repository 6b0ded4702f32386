/*
 * command.h - parsing of command lines from the host (docs/protocol.md).
 * Pure: turns a line into a command and its argument; control.c acts on it.
 */
#ifndef COMMAND_H
#define COMMAND_H

#include <stdint.h>

#include "vocab.h"

#include "config.h" /* COMMAND_LINE_MAX */

enum {
  CMD_NONE = 0, /* empty line: ignored, no reply */
  CMD_REPORT,
  CMD_RESET,
  CMD_STOP,
  CMD_START,
  CMD_RATE,
  CMD_STATUS,
  CMD_HELP,
  CMD_INTERVAL,
  CMD_MODE,  /* arg: MODE_* */
  CMD_RANGE, /* arg: RANGE_* (g-select code) */
  CMD_SAVE,
  CMD_LOAD,
  CMD_DEFAULTS,
  CMD_ECHO, /* arg: 0 off, 1 on; none: show the setting */
  CMD_UNITS /* arg: 0 phys, 1 counts; none: show the setting */
};
#define CMD_COUNT 15 /* commands, CMD_REPORT .. CMD_UNITS */

/* Kinds of argument a command takes (command_arg_kind). */
enum { ARG_NONE, ARG_COUNT, ARG_RATE, ARG_SECONDS, ARG_MODE, ARG_RANGE, ARG_ONOFF, ARG_UNITS };

/* The word of command id (CMD_REPORT..), in flash; the kind of its argument. */
const char *command_word(uint8_t id);
uint8_t command_arg_kind(uint8_t id);

/* Error codes of `error:<code>` replies. */
#define CMD_OK 0
#define CMD_ERR_UNKNOWN 1
#define CMD_ERR_ARG 2
#define CMD_ERR_LONG 3
#define CMD_ERR_STATE 4
#define CMD_ERR_LOST 5    /* bytes of the line were lost on the way in */
#define CMD_ERR_BYTE 6    /* a byte no command holds: NUL, a control, 8-bit */
#define CMD_ERR_TIMEOUT 7 /* no end of line within CONSOLE_TIMEOUT_MS of silence */

typedef struct {
  uint8_t id;      /* CMD_* */
  uint8_t has_arg; /* a number followed the word */
  uint32_t arg;
} command_t;

/* Parse one line (NUL-terminated, no end of line). Returns CMD_OK or a
 * CMD_ERR_* code; on CMD_OK *out holds the command (CMD_NONE for blank),
 * on CMD_ERR_ARG out->id names the command whose argument is wrong. */
uint8_t command_parse(const char *line, command_t *out);

#endif /* COMMAND_H */
