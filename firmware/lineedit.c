/* lineedit.c - see lineedit.h. */
#include "lineedit.h"

uint8_t lineedit_feed(lineedit_t *l, uint8_t c, uint8_t lost)
{
  if (lost)
    l->overflow |= LINE_LOST; /* never run a line with bytes missing */
  if (c == '\r' || c == '\n') {
    l->text[l->len] = 0;
    l->ended = 1;
    return LINE_ENDED;
  }
  if (c == 0x03 || c == 0x1B) {
    l->overflow = LINE_DROP; /* the echo shows it whole, then it goes */
    l->ended = 1;
    return LINE_DROPPED;
  }
  if (c == 0x08 || c == 0x7F) {
    if (l->len && !(l->overflow & LINE_LONG))
      l->len--;
    if (l->keep > l->len)
      l->keep = l->len;
  } else if (l->len < COMMAND_LINE_MAX) {
    l->text[l->len++] = (char)c;
  } else {
    l->overflow |= LINE_LONG; /* the whole line is refused at its end */
  }
  return LINE_TYPING;
}

static void put_n(void (*put)(uint8_t c), uint8_t *n, char c)
{
  put((uint8_t)c);
  ++*n;
}

static char shown_as(char c)
{
  return (c < 0x20 || c > 0x7E || c == '$') ? '?' : c;
}

uint8_t lineedit_echo(lineedit_t *l, uint8_t final, void (*put)(uint8_t c))
{
  uint8_t n = 0;
  if (final && !l->ended)
    return 0;
  if (!l->open) {
    if (!l->len && !l->ended)
      return 0; /* nothing typed yet */
    if (!l->len && !l->shown) { /* a blank or dropped line, nothing shown */
      if (l->overflow & LINE_DROP)
        lineedit_next(l);
      else
        l->ended = 0;
      return 0;
    }
    put_n(put, &n, '>');
    put_n(put, &n, ' ');
    l->open = 1;
  }
  while (l->shown > l->keep) {
    if (n + 3u > LINEEDIT_ECHO_MAX - 2u)
      return n; /* more next time */
    put_n(put, &n, '\b');
    put_n(put, &n, ' ');
    put_n(put, &n, '\b');
    l->shown--;
  }
  while (l->shown < l->len && n < LINEEDIT_ECHO_MAX - 2u)
    put_n(put, &n, shown_as(l->text[l->shown++]));
  l->keep = l->shown;
  if (l->ended && l->shown == l->len) {
    put_n(put, &n, '\r');
    put_n(put, &n, '\n');
    l->open = 0;
    l->shown = l->keep = 0;
    l->ended = 0;
    if (l->overflow & LINE_DROP)
      lineedit_next(l);
  }
  return n;
}

void lineedit_next(lineedit_t *l)
{
  l->len = 0;
  l->overflow = 0;
  l->ended = 0;
  l->shown = l->keep = 0;
  l->open = 0;
}
