/*
 * sim_serial.c - the device's UART seen from the host: host bytes paced at
 * the baud rate the firmware programmed (honouring simavr's receive FIFO
 * flow control), device bytes captured and framed into protocol lines
 * checked with the firmware's own CRC (crc.c).
 */
#include "harness.h"

#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "sim_io.h"
#include "sim_regbit.h"

#include "crc.h"

/* the accessors of avr_uart.h's receive FIFO (avr_uart_t.input) */
DEFINE_FIFO(uint16_t, uart_fifo);

/* ---- host -> device: paced UART input -------------------------------- */

/* One byte on the wire: start + 8 data + stop bit(s), at the baud rate
 * the firmware programmed. */
avr_cycle_count_t byte_cycles(void)
{
  avr_t *avr = g.avr;
  avr_uart_t *u = g.uart;
  uint32_t ubrr = avr_regbit_get(avr, u->ubrrl) |
                  (uint32_t)avr_regbit_get(avr, u->ubrrh) << 8;
  uint32_t bits = 10 + avr_regbit_get(avr, u->usbs);
  return (avr_cycle_count_t)bits * (ubrr + 1) * (avr_regbit_get(avr, u->u2x) ? 8 : 16);
}

/* Sends the next queued byte, then comes back one byte time later.  While
 * simavr's receive FIFO is full (XOFF) it waits, polling the FIFO once a
 * byte time, so a missed XON cannot stall it. */
static avr_cycle_count_t tx_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
  (void)param;
  if (!g.txq_len) {
    g.tx_busy = 0;      /* restarted by tx_push() */
    return 0;
  }
  if (g.xoff || uart_fifo_isfull(&g.uart->input)) {
    if (uart_fifo_isfull(&g.uart->input))
      return when + byte_cycles();
    g.xoff = 0;
  }
  uint8_t c = g.txq[g.txq_head++];
  g.txq_len--;
  if (!g.txq_len)
    g.txq_head = 0;
  if (!avr_regbit_get(avr, g.uart->rxen))
    g.bytes_lost++;     /* simavr drops it, as the hardware would */
  avr_raise_irq(g.uart_irq + UART_IRQ_INPUT, c);
  g.bytes_in++;
  g.tx_free_at = when + byte_cycles();
  if (!g.txq_len) {
    g.tx_busy = 0;
    return 0;
  }
  return g.tx_free_at;
}

void tx_kick(void)
{
  if (g.tx_busy || !g.txq_len)
    return;
  avr_cycle_count_t now = g.avr->cycle;
  g.tx_busy = 1;
  avr_cycle_timer_register(g.avr, g.tx_free_at > now ? g.tx_free_at - now : 1,
                           tx_timer, NULL);
}

void tx_push(const uint8_t *b, size_t n)
{
  if (g.txq_head + g.txq_len + n > g.txq_cap) {
    memmove(g.txq, g.txq + g.txq_head, g.txq_len);
    g.txq_head = 0;
    if (g.txq_len + n > g.txq_cap) {
      g.txq_cap = 2 * (g.txq_len + n) + 256;
      g.txq = realloc(g.txq, g.txq_cap);
      if (!g.txq)
        die(EXIT_FAIL, "out of memory");
    }
  }
  memcpy(g.txq + g.txq_head + g.txq_len, b, n);
  g.txq_len += n;
  tx_kick();
}

static void xon_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  (void)irq; (void)param;
  if (value)
    g.xoff = 0;
}

static void xoff_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  (void)irq; (void)param;
  if (value && !g.xoff)
    g.xoffs++;
  g.xoff = value != 0;
}

/* A harness command: ends an unterminated user line first, so that the
 * two never merge into one command. */
void send_cmd(const char *fmt, ...)
{
  char buf[64];
  va_list ap;
  if (g.user_line_len) {
    tx_push((const uint8_t *)"\r", 1);
    g.user_line_len = 0;
  }
  va_start(ap, fmt);
  int n = vsnprintf(buf, sizeof buf - 1, fmt, ap);
  va_end(ap);
  buf[n++] = '\r';
  tx_push((const uint8_t *)buf, (size_t)n);
}

/* User text: remember whether it left a line open (send_cmd closes it). */
void send_user(const uart_in_t *u)
{
  for (size_t i = 0; i < u->len; i++) {
    if (u->bytes[i] == '\r' || u->bytes[i] == '\n')
      g.user_line_len = 0;
    else
      g.user_line_len++;
  }
  tx_push(u->bytes, u->len);
}

/* ---- device -> host: capture and framing ------------------------------ */

/* The protocol's CRC, computed by the firmware's own crc.c. */
static uint16_t line_crc(const char *s, size_t n)
{
  uint16_t c = CRC16_INIT;
  while (n--)
    c = crc16_update(c, (uint8_t)*s++);
  return c;
}

static void end_line(void)
{
  char *star = NULL;
  g.in_line = 0;
  g.line[g.line_len] = 0;
  for (int i = g.line_len - 1; i >= 0; i--)
    if (g.line[i] == '*') {
      star = g.line + i;
      break;
    }
  if (!star || g.line + g.line_len - star != 5) {
    if (g.bad_frame++ == 0 && !g.pty)
      warn("t=%.6f s: device line without a *CRC: $%s", sim_time(), g.line);
    return;
  }
  char *end;
  unsigned long crc = strtoul(star + 1, &end, 16);
  size_t len = (size_t)(star - g.line);
  int crc_ok = *end == 0 && crc == line_crc(g.line, len);
  *star = 0;
  on_line(g.line, len, crc_ok);
}

static void uart_out(avr_irq_t *irq, uint32_t value, void *param)
{
  uint8_t c = (uint8_t)value;
  (void)irq; (void)param;
  if (g.out)
    putc(c, g.out);
  g.bytes_out++;
  if (g.pty)
    term_out(c);
  if (g.state == ST_DRAIN) {
    if (c == '\n')
      g.state = ST_DONE;
    return;
  }
  if (c == '$') {
    g.in_line = 1;
    g.line_len = 0;
  } else if (!g.in_line) {
    return;
  } else if (c == '\r' || c == '\n') {
    end_line();
  } else if (g.line_len < LINE_MAX_LEN - 1) {
    g.line[g.line_len++] = (char)c;
  } else {
    g.in_line = 0;
    if (g.bad_frame++ == 0 && !g.pty)
      warn("t=%.6f s: device line longer than %d characters", sim_time(),
           LINE_MAX_LEN);
  }
}

void serial_connect(void)
{
  avr_irq_register_notify(g.uart_irq + UART_IRQ_OUTPUT, uart_out, NULL);
  avr_irq_register_notify(g.uart_irq + UART_IRQ_OUT_XON, xon_notify, NULL);
  avr_irq_register_notify(g.uart_irq + UART_IRQ_OUT_XOFF, xoff_notify, NULL);
  /* no simavr stdio echo, no sleeping while polling the UART */
  uint32_t flags = 0;
  avr_ioctl(g.avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
  flags &= ~(uint32_t)(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
  avr_ioctl(g.avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
}
