/* console.c - see console.h. */
#include "console.h"

#include "clock.h"
#include "command.h"
#include "crc.h"
#include "pgm.h"
#include "proto.h"
#include "settings.h"
#include "uart.h"

/* The timeout in clock ticks, rounded up. */
#define CONSOLE_TIMEOUT_TICKS                                                                                \
  ((CONSOLE_TIMEOUT_MS * (F_CPU / 1000UL) + CLOCK_TICK_CYCLES - 1UL) / CLOCK_TICK_CYCLES)
#if CONSOLE_TIMEOUT_TICKS > 250
#  error "CONSOLE_TIMEOUT_MS is longer than the console's clock can count at this F_CPU (clock.h)"
#endif

#if UART_STEP_MAX < 2 + COMMAND_LINE_MAX + 2
#  error "an echo line (> , the text, CR LF) must fit one output step"
#endif

/* flags */
#define READY 1  /* the line is complete (or refused) and waits to run */
#define RUN 2    /* taken: the end of its echo frees it */
#define OPEN 4   /* an echo line is on the screen: "> " out, its CR LF not yet */
#define DROP 8   /* that echo line was dropped: "^C" CR LF due */
#define STAR 16  /* the line's check `*XXXX` has begun: bytes are its digits */
#define DIGIT 32 /* the check's hex digits so far, in the 3 top bits (7: malformed) */
#define DIGITS (DIGIT * 7)

static struct {
  char text[COMMAND_LINE_MAX + 1];
  uint8_t len;
  uint8_t err; /* the CMD_ERR_* that refuses the line, 0 if none */
  uint8_t flags;
  uint8_t shown;                  /* characters of text on the screen (echo) */
  uint8_t keep;                   /* of them, still equal to text */
  uint16_t count[CONSOLE_COUNTS]; /* console.h's console_count() */
} con;

static void next(void)
{
  con.len = con.err = con.flags = con.shown = con.keep = 0;
}

char console_shown_as(char c)
{
  return (c < 0x20 || c > 0x7E || c == '$' || c == '*') ? '?' : c;
}

static void count(uint8_t i)
{
  if (con.count[i] != 0xFFFFu)
    con.count[i]++;
}

/* One received byte into the line. */
static void feed(uint8_t c)
{
  uint8_t f = con.flags;
  if (c == '\r' || c == '\n') {
    if ((f & STAR) && (uint8_t)(f & DIGITS) != 4 * DIGIT)
      con.err = CMD_ERR_LOST; /* a check cut short, changed or malformed */
    con.flags = f & (uint8_t) ~(STAR | DIGITS);
    if (con.len || con.err) /* blank lines are ignored (an echo line "> " stays open) */
      con.flags |= READY;
  } else if (c == 0x03 || c == 0x1B) {
    f &= (uint8_t) ~(STAR | DIGITS);
    if (f & OPEN)
      f |= DROP; /* shown: marked as dropped */
    con.flags = f;
    con.len = con.err = con.keep = 0; /* gone, lost bytes with it */
  } else if (f & STAR) {
    /* A digit of the check: the text is final; each digit must be the
     * next one of its CRC in upper-case hex.  The CRC is worked out again
     * for each digit rather than kept: two bytes of RAM are scarcer than
     * the few hundred cycles of a 16-character line. */
    uint16_t crc = CRC16_INIT;
    uint8_t i, d;
    for (i = 0; i < con.len; i++)
      crc = crc16_update(crc, (uint8_t)con.text[i]);
    for (i = f; i >= DIGIT; i = (uint8_t)(i - DIGIT)) /* the digits already taken */
      crc = (uint16_t)(crc << 4);
    d = (uint8_t)(crc >> 12);
    d = (uint8_t)(d + (d > 9 ? 'A' - 10 : '0'));
    if (d != c || (f & 4 * DIGIT)) /* 4 digits already (or malformed) */
      f |= DIGITS;                 /* never 4 digits again: refused at the end */
    else
      f += DIGIT;
    con.flags = f;
  } else if (c == '*') {
    con.flags = f | STAR;
  } else if (c == 0x08 || c == 0x7F) {
    if (con.len && con.err != CMD_ERR_LONG)
      con.len--;
    if (con.keep > con.len)
      con.keep = con.len;
  } else {
    if ((c < 0x20 && c != '\t') || c > 0x7E) {
      if (!con.err)
        con.err = CMD_ERR_BYTE; /* the first reason found is the one given */
      c = '?';
    }
    if (con.len < COMMAND_LINE_MAX)
      con.text[con.len++] = (char)c;
    else if (!con.err)
      con.err = CMD_ERR_LONG;
  }
}

void console_receive(void)
{
  int16_t c;
  /* A complete line stops the reading until it has run and its echo is
   * out: bytes wait in the RX ring (what it cannot hold is lost, and the
   * line it belonged to refused). */
  while (!(uint8_t)(con.flags & (READY | RUN)) && (c = uart_read()) >= 0) {
    clock_restart(); /* the silence starts again */
    if (c & (UART_READ_OVERRUN | UART_READ_FRAME))
      count(0); /* the USART's: the line's timing or its bits */
    if (c & UART_READ_RING)
      count(1);
    if (c & UART_READ_GAP)
      con.err = CMD_ERR_LOST; /* outranks every other reason */
    if (!(c & UART_READ_EMPTY))
      feed((uint8_t)c);
  }
}

/* The echo line on the screen ends: a dropped line's mark, CR LF. */
static void end_line(void)
{
  if (con.flags & DROP) {
    uart_write('^');
    uart_write('C');
  }
  uart_write('\r');
  uart_write('\n');
  con.flags &= (uint8_t) ~(OPEN | DROP);
  con.shown = con.keep = 0;
}

uint8_t console_close(void)
{
  if (!(con.flags & OPEN))
    return 1;
  if (uart_tx_room() < 4)
    return 0;
  end_line();
  return 1;
}

/* Write the echo due now, within one output step; `job`: the taken line's
 * echo, all of it and its end.  Returns 1 when that is out. */
static uint8_t echo(uint8_t job)
{
  uint8_t left = uart_tx_room(); /* at most one output step (uart.h) */
  if (left < 4)
    return 0;
  if (con.flags & DROP) {
    end_line();
    left = (uint8_t)(left - 4);
  }
  if (!(con.flags & OPEN)) {
    if (!con.len) { /* nothing typed (a refused empty line): no echo */
      if (job)
        next();
      return job;
    }
    if (left < 4)
      return 0;
    uart_write('>');
    uart_write(' ');
    left = (uint8_t)(left - 2);
    con.flags |= OPEN;
  }
  while (con.shown > con.keep) {
    if (left < 5)
      return 0; /* more next time */
    uart_write('\b');
    uart_write(' ');
    uart_write('\b');
    left = (uint8_t)(left - 3);
    con.shown--;
  }
  while (con.shown < con.len && left > 2) {
    uart_write((uint8_t)console_shown_as(con.text[con.shown++]));
    left--;
  }
  con.keep = con.shown;
  if (!job || con.shown != con.len)
    return 0;
  end_line(); /* CR LF: 2 bytes left, kept free above (no DROP here) */
  next();
  return 1;
}

uint8_t console_echo_job(void)
{
  return echo(1);
}

void console_poll(uint8_t live)
{
  console_receive();
  if (!(con.flags & (READY | RUN)) && (con.len | con.err | (con.flags & STAR)) &&
      clock_ticks() >= (uint8_t)CONSOLE_TIMEOUT_TICKS) {
    if (con.err != CMD_ERR_LOST)
      con.err = CMD_ERR_TIMEOUT;
    con.flags |= READY;
  }
  /* Nothing typed, shown or due: the loop's idle pass stays cheap. */
  if (live && settings.echo && (con.len | con.flags) && !(con.flags & RUN)) /* shown: OPEN is set */
    echo(0);
}

uint8_t console_ready(void)
{
  return con.flags & READY;
}

uint8_t console_take(const char **text)
{
  uint8_t err = con.err;
  con.text[con.len] = 0;
  *text = con.text;
  if (err == CMD_ERR_LOST || err == CMD_ERR_TIMEOUT)
    count((uint8_t)(err >> 1)); /* counts 2 and 3 */
#if CMD_ERR_LOST >> 1 != 2 || CMD_ERR_TIMEOUT >> 1 != 3
#  error "the lost and timed-out lines' counts are error code / 2"
#endif
  if (settings.echo)
    con.flags = (uint8_t)((con.flags & ~READY) | RUN); /* the echo job frees it */
  else
    next();
  return err;
}

void console_put_count(uint8_t i, char sep)
{
  if (!i) {
    proto_putc(sep);
    proto_puts_P(PSTR("rx="));
  } else {
    proto_putc(':');
  }
  proto_u32(con.count[i]);
}
