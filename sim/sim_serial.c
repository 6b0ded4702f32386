/*
 * sim_serial.c - the device's UART seen from the host: host bytes paced at
 * the baud rate the firmware programmed (honouring simavr's receive FIFO
 * flow control, unless --no-flow-control), device bytes captured and framed
 * into protocol lines checked with the firmware's own CRC (crc.c); both
 * ways through the link faults of sim_fault.c.
 */
#include "sim_serial.h"

#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "sim_io.h"
#include "sim_regbit.h"

#include "crc.h"
#include "sim_fault.h"
#include "sim_msg.h"

/* the accessors of avr_uart.h's receive FIFO (avr_uart_t.input) */
DEFINE_FIFO(uint16_t, uart_fifo);

/* ---- host -> device: paced UART input -------------------------------- */

/* One byte on the wire: start + 8 data + stop bit(s), at the baud rate
 * the firmware programmed. */
avr_cycle_count_t serial_byte_cycles(harness_t *h)
{
  avr_t *avr = h->avr;
  avr_uart_t *u = h->uart;
  uint32_t ubrr = avr_regbit_get(avr, u->ubrrl) |
                  (uint32_t)avr_regbit_get(avr, u->ubrrh) << 8;
  uint32_t bits = 10 + avr_regbit_get(avr, u->usbs);
  return (avr_cycle_count_t)bits * (ubrr + 1) *
         (avr_regbit_get(avr, u->u2x) ? 8 : 16);
}

/* Sends the next queued byte, then comes back one byte time later.  While
 * simavr's receive FIFO is full (XOFF) it waits, polling the FIFO once a
 * byte time, so a missed XON cannot stall it. */
static avr_cycle_count_t tx_timer(avr_t *avr, avr_cycle_count_t when,
                                  void *param)
{
  harness_t *h = param;
  if (!h->txq_len) {
    h->tx_busy = 0; /* restarted by tx_push() */
    return 0;
  }
  /* Without flow control the sender never waits: the chip's receive
   * buffer decides (fault_rx_full). */
  if (!h->fault.no_flow && (h->xoff || uart_fifo_isfull(&h->uart->input))) {
    if (uart_fifo_isfull(&h->uart->input))
      return when + serial_byte_cycles(h);
    h->xoff = 0;
  }
  uint8_t c = h->txq[h->txq_head++];
  int fe;
  h->txq_len--;
  if (!h->txq_len)
    h->txq_head = 0;
  h->bytes_in++;
  if (!avr_regbit_get(avr, h->uart->rxen))
    h->bytes_lost++; /* simavr drops it, as the hardware would */
  else if (fault_host_byte(h, &c, &fe) && !fault_rx_full(h)) {
    avr_raise_irq(h->uart_irq + UART_IRQ_INPUT, c | (fe ? UART_INPUT_FE : 0));
    fault_host_byte_delivered(h);
  }
  /* simavr's receiver takes 11 bit times a byte (it counts a parity bit
   * that 8N1 has not): without flow control the sender keeps its pace, or
   * simavr's own lag would overrun a chip that keeps up */
  avr_cycle_count_t gap = serial_byte_cycles(h);
  if (h->fault.no_flow && h->uart->cycles_per_byte > gap)
    gap = h->uart->cycles_per_byte;
  h->tx_free_at = when + gap;
  if (!h->txq_len) {
    h->tx_busy = 0;
    return 0;
  }
  return h->tx_free_at;
}

static void tx_kick(harness_t *h)
{
  if (h->tx_busy || !h->txq_len)
    return;
  avr_cycle_count_t now = h->avr->cycle;
  h->tx_busy = 1;
  avr_cycle_timer_register(
      h->avr, h->tx_free_at > now ? h->tx_free_at - now : 1, tx_timer, h);
}

void serial_push(harness_t *h, const uint8_t *b, size_t n)
{
  if (h->txq_head + h->txq_len + n > h->txq_cap) {
    memmove(h->txq, h->txq + h->txq_head, h->txq_len);
    h->txq_head = 0;
    if (h->txq_len + n > h->txq_cap) {
      h->txq_cap = 2 * (h->txq_len + n) + 256;
      h->txq = realloc(h->txq, h->txq_cap);
      if (!h->txq)
        die(EXIT_FAIL, "out of memory");
    }
  }
  memcpy(h->txq + h->txq_head + h->txq_len, b, n);
  h->txq_len += n;
  tx_kick(h);
}

static void xon_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  harness_t *h = param;
  (void)irq;
  if (value)
    h->xoff = 0;
}

static void xoff_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  harness_t *h = param;
  (void)irq;
  if (value && !h->xoff)
    h->xoffs++;
  h->xoff = value != 0;
}

/* A harness command: ends an unterminated user line first, so that the
 * two never merge into one command. */
void serial_send_cmd(harness_t *h, const char *fmt, ...)
{
  char buf[64];
  va_list ap;
  if (h->user_line_len) {
    serial_push(h, (const uint8_t *)"\r", 1);
    h->user_line_len = 0;
  }
  va_start(ap, fmt);
  int n = vsnprintf(buf, sizeof buf - 1, fmt, ap);
  va_end(ap);
  buf[n++] = '\r';
  serial_push(h, (const uint8_t *)buf, (size_t)n);
}

/* User text: remember whether it left a line open (send_cmd closes it). */
void serial_send_user(harness_t *h, const uart_in_t *u)
{
  for (size_t i = 0; i < u->len; i++) {
    if (u->bytes[i] == '\r' || u->bytes[i] == '\n')
      h->user_line_len = 0;
    else
      h->user_line_len++;
  }
  serial_push(h, u->bytes, u->len);
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

static void end_line(harness_t *h)
{
  char *star = NULL;
  h->in_line = 0;
  h->line[h->line_len] = 0;
  for (int i = h->line_len - 1; i >= 0; i--)
    if (h->line[i] == '*') {
      star = h->line + i;
      break;
    }
  if (!star || h->line + h->line_len - star != 5) {
    if (h->bad_frame++ == 0 && !h->pty)
      warn("t=%.6f s: device line without a *CRC: $%s", sim_time(h), h->line);
    return;
  }
  char *end;
  unsigned long crc = strtoul(star + 1, &end, 16);
  size_t len = (size_t)(star - h->line);
  int crc_ok = *end == 0 && crc == line_crc(h->line, len);
  *star = 0;
  if (h->on_line)
    h->on_line(h, h->line, len, crc_ok);
}

static void uart_out(avr_irq_t *irq, uint32_t value, void *param)
{
  harness_t *h = param;
  uint8_t c = (uint8_t)value;
  (void)irq;
  if (!fault_device_byte(h, &c))
    return; /* lost on the link */
  if (h->out)
    putc(c, h->out);
  h->bytes_out++;
  if (h->on_byte)
    h->on_byte(h, c);
  if (c == '$') {
    h->in_line = 1;
    h->line_len = 0;
  } else if (!h->in_line) {
    return;
  } else if (c == '\r' || c == '\n') {
    end_line(h);
  } else if (h->line_len < LINE_MAX_LEN - 1) {
    h->line[h->line_len++] = (char)c;
  } else {
    h->in_line = 0;
    if (h->bad_frame++ == 0 && !h->pty)
      warn("t=%.6f s: device line longer than %d characters", sim_time(h),
           LINE_MAX_LEN);
  }
}

void serial_connect(harness_t *h)
{
  avr_irq_register_notify(h->uart_irq + UART_IRQ_OUTPUT, uart_out, h);
  avr_irq_register_notify(h->uart_irq + UART_IRQ_OUT_XON, xon_notify, h);
  avr_irq_register_notify(h->uart_irq + UART_IRQ_OUT_XOFF, xoff_notify, h);
  /* no simavr stdio echo, no sleeping while polling the UART */
  uint32_t flags = 0;
  avr_ioctl(h->avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
  flags &= ~(uint32_t)(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
  avr_ioctl(h->avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
}

size_t serial_queued(const harness_t *h)
{
  return h->txq_len;
}

size_t serial_drop_queued(harness_t *h)
{
  size_t n = h->txq_len;
  h->txq_len = 0;
  h->txq_head = 0;
  h->user_line_len = 0;
  return n;
}

void serial_after_reset(harness_t *h)
{
  h->tx_busy = 0;
  h->tx_free_at = 0;
  h->xoff = 0;
  tx_kick(h);
}
