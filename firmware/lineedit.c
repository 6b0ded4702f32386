/* lineedit.c - see lineedit.h. */
#include "lineedit.h"

lineedit_t lineedit;

uint8_t lineedit_feed(lineedit_t *l, uint8_t c, uint8_t lost)
{
  if (lost)
    l->flags |= LINE_LOST; /* never run a line with bytes missing */
  if (c == '\r' || c == '\n') {
    l->text[l->len] = 0;
    l->flags |= LINE_ENDED_BIT;
    return LINE_ENDED;
  }
  if (c == 0x03 || c == 0x1B) {
    l->flags = (uint8_t)((l->flags & LINE_OPEN) | LINE_DROP | LINE_ENDED_BIT); /* echoed whole, then gone */
    return LINE_DROPPED;
  }
  if (c == 0x08 || c == 0x7F) {
    if (l->len && !(l->flags & LINE_LONG))
      l->len--;
    if (l->keep > l->len)
      l->keep = l->len;
    return LINE_TYPING;
  }
  if ((c < 0x20 && c != '\t') || c > 0x7E) {
    if (!(l->flags & LINE_LONG))
      l->flags |= LINE_BYTE; /* the first reason found is the one given */
    c = '?';
  }
  if (l->len < COMMAND_LINE_MAX) {
    l->text[l->len++] = (char)c;
  } else if (!(l->flags & LINE_BYTE)) {
    l->flags |= LINE_LONG; /* the whole line is refused at its end */
  }
  return LINE_TYPING;
}

static void put_n(void (*put)(uint8_t c), uint8_t *n, char c)
{
  put((uint8_t)c);
  ++*n;
}

char lineedit_shown_as(char c)
{
  return (c < 0x20 || c > 0x7E || c == '$' || c == '*') ? '?' : c;
}

uint8_t lineedit_echo(lineedit_t *l, uint8_t final, void (*put)(uint8_t c), uint8_t room)
{
  uint8_t n = 0;
  if ((final && !lineedit_ended(l)) || room < 4)
    return 0;
  if (room > LINEEDIT_ECHO_MAX)
    room = LINEEDIT_ECHO_MAX;
  if (!lineedit_open(l)) {
    if (!l->len && !lineedit_ended(l))
      return 0; /* nothing typed yet */
    if (!l->len && !l->shown) { /* a blank or dropped line, nothing shown */
      if (l->flags & (LINE_DROP | LINE_RUN))
        lineedit_next(l);
      else
        l->flags &= (uint8_t)~LINE_ENDED_BIT;
      return 0;
    }
    put_n(put, &n, '>');
    put_n(put, &n, ' ');
    l->flags |= LINE_OPEN;
  }
  while (l->shown > l->keep) {
    if (n + 3u > room - 2u)
      return n; /* more next time */
    put_n(put, &n, '\b');
    put_n(put, &n, ' ');
    put_n(put, &n, '\b');
    l->shown--;
  }
  while (l->shown < l->len && n < room - 2u)
    put_n(put, &n, lineedit_shown_as(l->text[l->shown++]));
  l->keep = l->shown;
  if (lineedit_ended(l) && l->shown == l->len) {
    put_n(put, &n, '\r');
    put_n(put, &n, '\n');
    l->flags &= (uint8_t)~(LINE_OPEN | LINE_ENDED_BIT);
    l->shown = l->keep = 0;
    if (l->flags & (LINE_DROP | LINE_RUN))
      lineedit_next(l);
  }
  return n;
}

__attribute__((noinline)) void lineedit_next(lineedit_t *l)
{
  l->len = 0;
  l->flags = 0;
  l->shown = l->keep = 0;
}
