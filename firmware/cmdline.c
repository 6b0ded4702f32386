/* cmdline.c - see cmdline.h.  The line and its editing are lineedit's
 * (one editor, pure); this module moves the bytes in and names the error
 * that refuses a line. */
#include "cmdline.h"

#include "command.h"
#include "lineedit.h"
#include "settings.h"
#include "uart.h"

void cmdline_poll(void)
{
  int16_t c;
  /* An ended line stops the reading until it has run and, echo on, its
   * echo is out (the echo shows the line's text). */
  while (!(lineedit.flags & LINE_READY) && !lineedit_ended(&lineedit) && (c = uart_read()) >= 0) {
    uint8_t r = lineedit_feed(&lineedit, (uint8_t)c, (c & UART_READ_GAP) != 0);
    if (r == LINE_ENDED && (lineedit.len || (lineedit.flags & LINE_REFUSED)))
      lineedit.flags |= LINE_READY; /* blank lines are ignored */
    if (!settings.echo) {
      lineedit.flags &= (uint8_t)~LINE_ENDED_BIT;
      if (r != LINE_TYPING && !(lineedit.flags & LINE_READY))
        lineedit_next(&lineedit); /* dropped or blank: gone */
    }
  }
}

uint8_t cmdline_ready(void)
{
  return (lineedit.flags & LINE_READY) != 0;
}

uint8_t cmdline_take(const char **text)
{
  uint8_t f = lineedit.flags;
  *text = lineedit.text;
  /* The line is taken: with its echo still due, the echo job ends it
   * (reading waits for that); else the next line starts now, since a
   * command may poll the receiver (sample_feed) while it runs. */
  if (lineedit_ended(&lineedit))
    lineedit.flags = (uint8_t)((f & ~LINE_READY) | LINE_RUN);
  else
    lineedit_next(&lineedit);
  /* lost bytes outrank the rest (the line's end may be what was lost) */
  return f & LINE_LOST ? CMD_ERR_LOST : f & LINE_BYTE ? CMD_ERR_BYTE : f & LINE_LONG ? CMD_ERR_LONG : 0;
}
