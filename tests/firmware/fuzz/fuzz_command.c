/*
 * fuzz_command - command_parse() on arbitrary bytes (firmware/command.c).
 * The parser takes NUL-terminated lines, so the input is cut at its first
 * NUL here; what the device does with a NUL (or any byte) inside a line
 * received from the UART is fuzz_cmdline's subject, on whole streams.
 *
 * Written against the parser's contract, not its word list, so that new
 * commands and argument kinds need no change here.  For any line:
 *   - the result is CMD_OK or one of the CMD_ERR_* codes of docs/protocol.md;
 *   - a blank line (nothing but spaces and tabs) is CMD_OK with CMD_NONE
 *     (or CMD_ERR_LONG, if too long); a line that is not blank never parses
 *     to CMD_NONE;
 *   - CMD_ERR_LONG only for a line longer than COMMAND_LINE_MAX;
 *   - parsing is deterministic and leaves the line untouched;
 *   - it is case-insensitive: lowercasing or uppercasing the ASCII letters
 *     gives the same result (and the same command, argument included);
 *   - trailing spaces and tabs change nothing: the line with them stripped,
 *     and with " \t" appended, parse the same (unless one is CMD_ERR_LONG);
 *   - words are separated by spaces or tabs: with every run of them made a
 *     single space between words (none before the first or after the last)
 *     the line parses the same (unless it was CMD_ERR_LONG);
 *   - nothing is read past the NUL: every line is copied into a heap block
 *     of exactly its length + 1, which ASan guards.
 * Also vocab_rate_ok() against the seven rates, on the input's first 4 bytes.
 * Lines run up to and beyond COMMAND_LINE_MAX (the run sets -max_len).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "command.h"
#include "fuzz_util.h"

typedef struct {
  uint8_t r;
  command_t c;
} result_t;

static result_t parse(const char *text, size_t len)
{
  result_t res;
  char *line = malloc(len + 1);
  char *copy = malloc(len + 1);
  command_t *out = malloc(sizeof *out); /* exactly sized too */
  memcpy(line, text, len);
  line[len] = 0;
  memcpy(copy, line, len + 1);
  memset(out, 0xA5, sizeof *out);
  res.r = command_parse(line, out);
  res.c = *out;
  FUZZ_CHECK(memcmp(line, copy, len + 1) == 0, "command_parse wrote into its line \"%s\"", copy);
  free(line);
  free(copy);
  free(out);
  return res;
}

static int same(const result_t *a, const result_t *b)
{
  if (a->r != b->r)
    return 0;
  if (a->r != CMD_OK) /* the command is not used on an error */
    return 1;
  return a->c.id == b->c.id && a->c.has_arg == b->c.has_arg && a->c.arg == b->c.arg;
}

static void show(char *buf, size_t size, const char *s, size_t len, const result_t *r)
{
  size_t n = 0, i;
  n += (size_t)snprintf(buf, size, "\"");
  for (i = 0; i < len && n + 8 < size; i++) {
    unsigned char c = (unsigned char)s[i];
    n += (size_t)snprintf(buf + n, size - n,
                          (c >= 0x20 && c < 0x7F && c != '"' && c != '\\') ? "%c" : "\\x%02X", c);
  }
  snprintf(buf + n, size - n, "\" -> r=%u id=%u has_arg=%u arg=%lu", r->r, r->c.id, r->c.has_arg,
           (unsigned long)r->c.arg);
}

#define SAME_OR_DIE(what, s1, n1, r1, s2, n2, r2)                                                            \
  do {                                                                                                       \
    if (!same(&(r1), &(r2))) {                                                                               \
      char m1[400], m2[400];                                                                                 \
      show(m1, sizeof m1, s1, n1, &(r1));                                                                    \
      show(m2, sizeof m2, s2, n2, &(r2));                                                                    \
      FUZZ_CHECK(0, "%s:\n  %s\n  %s", what, m1, m2);                                                        \
    }                                                                                                        \
  } while (0)

static int is_space(char c)
{
  return c == ' ' || c == '\t';
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  const char *text = (const char *)data;
  size_t len = strnlen(text, size), i, stripped;
  char *var = malloc(len + 3);
  result_t r, r2;
  int blank = 1;
  char msg[400];

  for (i = 0; i < len; i++)
    if (!is_space(text[i]))
      blank = 0;

  r = parse(text, len);
  show(msg, sizeof msg, text, len, &r);
  FUZZ_CHECK(r.r == CMD_OK || r.r == CMD_ERR_UNKNOWN || r.r == CMD_ERR_ARG || r.r == CMD_ERR_LONG ||
                 r.r == CMD_ERR_STATE,
             "not a protocol result code: %s", msg);
  if (blank) /* (too long a blank line may still be refused as long) */
    FUZZ_CHECK((r.r == CMD_OK && r.c.id == CMD_NONE) || r.r == CMD_ERR_LONG,
               "a blank line must be CMD_OK, CMD_NONE: %s", msg);
  else
    FUZZ_CHECK(r.r != CMD_OK || r.c.id != CMD_NONE, "a line with words parsed to CMD_NONE: %s", msg);
  if (r.r == CMD_ERR_LONG)
    FUZZ_CHECK(len > COMMAND_LINE_MAX, "CMD_ERR_LONG for a line of %zu <= %d characters: %s", len,
               COMMAND_LINE_MAX, msg);

  /* Deterministic. */
  r2 = parse(text, len);
  SAME_OR_DIE("parsing the same line twice differs", text, len, r, text, len, r2);

  /* Case-insensitive, both ways. */
  for (i = 0; i < len; i++)
    var[i] = (text[i] >= 'A' && text[i] <= 'Z') ? (char)(text[i] - 'A' + 'a') : text[i];
  r2 = parse(var, len);
  SAME_OR_DIE("lowercasing changed the result", text, len, r, var, len, r2);
  for (i = 0; i < len; i++)
    var[i] = (text[i] >= 'a' && text[i] <= 'z') ? (char)(text[i] - 'a' + 'A') : text[i];
  r2 = parse(var, len);
  SAME_OR_DIE("uppercasing changed the result", text, len, r, var, len, r2);

  /* Trailing spaces and tabs: stripped, and appended. */
  stripped = len;
  while (stripped && is_space(text[stripped - 1]))
    stripped--;
  if (stripped != len) {
    r2 = parse(text, stripped);
    if (r.r != CMD_ERR_LONG && r2.r != CMD_ERR_LONG)
      SAME_OR_DIE("trailing blanks changed the result", text, len, r, text, stripped, r2);
  }
  memcpy(var, text, len);
  var[len] = ' ';
  var[len + 1] = '\t';
  r2 = parse(var, len + 2);
  if (r.r != CMD_ERR_LONG && r2.r != CMD_ERR_LONG)
    SAME_OR_DIE("appending \" \\t\" changed the result", text, len, r, var, len + 2, r2);

  /* Words are separated by spaces or tabs: any run of them, leading and
   * trailing ones too, may become a single space between words (when the
   * line was not refused as too long: the shorter one may be accepted). */
  {
    size_t n = 0;
    int gap = 0;
    for (i = 0; i < len; i++) {
      if (is_space(text[i])) {
        gap = 1;
        continue;
      }
      if (gap && n)
        var[n++] = ' ';
      gap = 0;
      var[n++] = text[i];
    }
    if (n != len || memcmp(var, text, len) != 0) {
      r2 = parse(var, n);
      if (r.r != CMD_ERR_LONG)
        SAME_OR_DIE("collapsing blanks changed the result", text, len, r, var, n, r2);
    }
  }

  /* vocab_rate_ok: exactly the seven rates of docs/protocol.md. */
  if (size >= 4) {
    uint32_t hz =
        (uint32_t)data[0] | (uint32_t)data[1] << 8 | (uint32_t)data[2] << 16 | (uint32_t)data[3] << 24;
    if (data[3] == 0xFF) /* near the rates too */
      hz &= 0x7FF;
    FUZZ_CHECK(!vocab_rate_ok(hz) == !(hz == 50 || hz == 100 || hz == 200 || hz == 250 || hz == 500 ||
                                       hz == 1000 || hz == 1250 || hz == 1500),
               "vocab_rate_ok(%lu)", (unsigned long)hz);
  }

  free(var);
  return 0;
}
