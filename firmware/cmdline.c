/* cmdline.c - see cmdline.h. */
#include "cmdline.h"

#include "command.h"
#include "uart.h"

static struct {
  char text[COMMAND_LINE_MAX + 1];
  uint8_t len;
  uint8_t refuse; /* CMD_ERR_* that refuses the line at its end, or 0 */
  uint8_t ready;
} line;

/* A reason to refuse the line; the first one found is kept, except that
 * lost bytes outrank the rest (the line's end may be what was lost). */
static void refuse(uint8_t code)
{
  if (!line.refuse || code == CMD_ERR_LOST)
    line.refuse = code;
}

void cmdline_poll(void)
{
  int16_t c;
  while (!line.ready && (c = uart_read()) >= 0) {
    if (c & UART_READ_GAP) {
      refuse(CMD_ERR_LOST); /* never run a line with bytes missing */
      c &= 0xFF;
    }
    if (c == '\r' || c == '\n') {
      line.text[line.len] = 0;
      line.ready = line.len || line.refuse; /* blank lines are ignored */
      line.len = 0;
    } else if (c == '\b' || c == 0x7F) {
      if (line.len)
        line.len--;
    } else if ((c < 0x20 && c != '\t') || c > 0x7E) {
      refuse(CMD_ERR_BYTE); /* NUL, controls, 8-bit bytes */
    } else if (line.len < COMMAND_LINE_MAX) {
      line.text[line.len++] = (char)c;
    } else {
      refuse(CMD_ERR_LONG); /* discard the whole line at its end */
    }
  }
}

uint8_t cmdline_ready(void)
{
  return line.ready;
}

uint8_t cmdline_take(const char **text)
{
  uint8_t code = line.refuse;
  line.ready = 0;
  line.refuse = 0;
  *text = line.text;
  return code;
}
