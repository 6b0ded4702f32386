/*
 * fuzz_cmdline - the console's line receiver (firmware/console.c, echo off)
 * and the parser on arbitrary byte streams: NULs, controls, 8-bit bytes, BS/DEL, CR/LF,
 * and a receive gap, all included.  Checked against a model written here
 * from docs/protocol.md ("Commands"):
 *   - lines end at CR or LF; blank ones give nothing;
 *   - BS and DEL erase the character before them;
 *   - a line holding a byte other than printable ASCII, TAB, BS, DEL is
 *     refused whole (error:6), one longer than 16 characters too
 *     (error:3), one with a receive gap too (error:5, which outranks);
 *     the first reason found is the one given otherwise;
 *   - a line ending in a check (`*` and the CRC of its text) that is not
 *     exactly right is refused with error:5, the check not in the text;
 *   - any other line reaches the parser exactly as the model assembled it
 *     (nothing after a NUL is ever parsed: such a line never gets there);
 *   - echo off, nothing is written.
 * The clock stands still here (no line times out): fuzz_line has the rest
 * of the console, echo and timeout included, in the whole device.
 * Input: byte 0 chooses a gap (odd: a gap before byte byte0/2 of the
 * stream), the rest is the stream.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "clock.h"
#include "command.h"
#include "console.h"
#include "fuzz_util.h"
#include "settings.h"
#include "uart.h"
#include "../native/ref_crc16.h"

settings_t settings; /* echo off: the receiver alone (no output) */

static const uint8_t *stream;
static size_t stream_len, stream_pos, gap_at = (size_t)-1;

static int gap_taken;

int16_t uart_read(void)
{
  int16_t gap = 0;
  if (stream_pos == gap_at && !gap_taken) {
    gap_taken = 1;
    gap = UART_READ_GAP | UART_READ_RING;
  }
  if (stream_pos >= stream_len)
    return gap ? (int16_t)(gap | UART_READ_EMPTY) : -1; /* a gap with no byte after it */
  return (int16_t)(gap | stream[stream_pos++]);
}

void uart_write(uint8_t c)
{
  FUZZ_CHECK(0, "echo off, yet the console wrote 0x%02X", c);
}

uint8_t uart_tx_room(void)
{
  return 0;
}

uint8_t clock_ticks(void)
{
  return 0;
}

void clock_restart(void) {}

uint8_t uart_rx_pending(void)
{
  return stream_pos < stream_len;
}

typedef struct {
  uint8_t code;
  char text[COMMAND_LINE_MAX + 1];
} event_t;

/* The model: the events the stream must give, in order.  A `*` starts the
 * line's check: every byte after it but the end, Ctrl-C and Esc is a digit
 * of it; not exactly the 4 upper-case hex digits of the CRC of the text
 * before `*` (as held, a bad byte as '?'): error:5. */
static size_t model(const uint8_t *s, size_t n, size_t gap, event_t *ev)
{
  size_t count = 0, i, ndig = 0;
  char text[COMMAND_LINE_MAX + 1], check[4];
  size_t len = 0;
  uint8_t code = 0;
  int star = 0;
  for (i = 0; i < n; i++) {
    uint8_t c = s[i];
    if (i == gap)
      code = CMD_ERR_LOST;
    if (c == '\r' || c == '\n') {
      char want[8];
      snprintf(want, sizeof want, "%04X", ref_crc16(text, len));
      if (star && (ndig != 4 || memcmp(check, want, 4) != 0))
        code = CMD_ERR_LOST;
      star = 0;
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
      star = 0;
    } else if (star) {
      if (ndig < 4)
        check[ndig] = (char)c;
      ndig++;
    } else if (c == '*') {
      star = 1;
      ndig = 0;
    } else if (c == 0x08 || c == 0x7F) {
      if (len && code != CMD_ERR_LONG) /* a line that overflowed stays refused whole */
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
    gap_taken = 0;
    console_receive();
    if (console_ready())
      console_take(&t);
    stream = save;
    stream_len = save_len;
    stream_pos = 0;
    gap_at = save_gap;
    gap_taken = 0;
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
