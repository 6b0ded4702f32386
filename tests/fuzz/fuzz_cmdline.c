/*
 * fuzz_cmdline - the command-line receiver (firmware/console.c) and parser
 * on arbitrary byte streams: NULs, controls, 8-bit bytes, BS/DEL, CR/LF,
 * and a receive gap, all included.  Checked against a model written here
 * from docs/protocol.md ("Commands"):
 *   - lines end at CR or LF; blank ones give nothing;
 *   - BS and DEL erase the character before them;
 *   - a line holding a byte other than printable ASCII, TAB, BS, DEL is
 *     refused whole (error:6), one longer than 16 characters too
 *     (error:3), one with a receive gap too (error:5, which outranks);
 *     the first reason found is the one given otherwise;
 *   - any other line reaches the parser exactly as the model assembled it
 *     (nothing after a NUL is ever parsed: such a line never gets there).
 * Input: byte 0 chooses a gap (odd: a gap before byte byte0/2 of the
 * stream), the rest is the stream.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "clock.h"
#include "console.h"
#include "command.h"
#include "fuzz_util.h"
#include "settings.h"
#include "uart.h"

settings_t settings; /* echo off: the receiver alone (no output) */

static const uint8_t *stream;
static size_t stream_len, stream_pos, gap_at = (size_t)-1;

int16_t uart_read(void)
{
  int16_t gap;
  if (stream_pos >= stream_len)
    return -1;
  gap = stream_pos == gap_at ? UART_READ_GAP : 0;
  return (int16_t)(gap | stream[stream_pos++]);
}

uint8_t uart_rx_pending(void)
{
  return stream_pos < stream_len;
}

/* Echo off: nothing is written; the clock stands still (no timeout). */
void uart_write(uint8_t c)
{
  (void)c;
}

uint8_t uart_tx_room(void)
{
  return 0;
}

uint8_t clock_now(void)
{
  return 0;
}

typedef struct {
  uint8_t code;
  char text[COMMAND_LINE_MAX + 1];
} event_t;

/* The model: the events the stream must give, in order. */
static size_t model(const uint8_t *s, size_t n, size_t gap, event_t *ev)
{
  size_t count = 0, i;
  char text[COMMAND_LINE_MAX + 1];
  size_t len = 0;
  uint8_t code = 0;
  for (i = 0; i < n; i++) {
    uint8_t c = s[i];
    if (i == gap)
      code = CMD_ERR_LOST;
    if (c == '\r' || c == '\n') {
      if (len || code) {
        ev[count].code = code;
        memcpy(ev[count].text, text, len);
        ev[count].text[len] = 0;
        count++;
      }
      len = 0;
      code = 0;
    } else if (c == 0x03 || c == 0x1B) {
      len = 0; /* Ctrl-C, Esc: the line is dropped, lost bytes with it */
      code = 0;
    } else if (c == 0x08 || c == 0x7F) {
      if (len)
        len--;
    } else if ((c < 0x20 && c != '\t') || c > 0x7E) {
      if (!code)
        code = CMD_ERR_BYTE;
      if (len < COMMAND_LINE_MAX)
        text[len++] = '?'; /* it takes its place, shown as '?' */
    } else if (len < COMMAND_LINE_MAX) {
      text[len++] = (char)c;
    } else if (!code) {
      code = CMD_ERR_LONG;
    }
  }
  return count;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  event_t *ev;
  size_t count, k = 0;
  if (size < 1)
    return 0;
  stream = data + 1;
  stream_len = size - 1;
  stream_pos = 0;
  gap_at = (data[0] & 1) ? data[0] / 2u : (size_t)-1;
  ev = malloc((stream_len + 1) * sizeof *ev);
  count = model(stream, stream_len, gap_at, ev);
  /* the receiver keeps its partial line between inputs: flush it first */
  {
    const uint8_t *save = stream;
    size_t save_len = stream_len, save_gap = gap_at;
    static const uint8_t cr = '\r';
    const char *t;
    stream = &cr;
    stream_len = 1;
    stream_pos = 0;
    gap_at = (size_t)-1;
    console_receive();
    if (console_ready())
      console_take(&t);
    stream = save;
    stream_len = save_len;
    stream_pos = 0;
    gap_at = save_gap;
  }
  while (stream_pos < stream_len || console_ready()) {
    console_receive();
    if (!console_ready())
      continue;
    const char *text;
    uint8_t code = console_take(&text);
    FUZZ_CHECK(k < count, "a line the model does not have (code %u)", code);
    FUZZ_CHECK(code == ev[k].code, "line %zu: code %u, model %u", k, code, ev[k].code);
    if (!code) {
      command_t cmd;
      FUZZ_CHECK(strcmp(text, ev[k].text) == 0, "line %zu: \"%s\", model \"%s\"", k, text, ev[k].text);
      for (const char *p = text; *p; p++)
        FUZZ_CHECK((*p >= 0x20 && *p <= 0x7E) || *p == '\t', "a byte 0x%02X reached the parser",
                   (unsigned)(uint8_t)*p);
      (void)command_parse(text, &cmd);
    }
    k++;
  }
  FUZZ_CHECK(k == count, "%zu lines, model %zu", k, count);
  free(ev);
  return 0;
}
