/*
 * uart.c - USART0 at BAUD with TX/RX rings.  The ISRs only move bytes.
 */
#include "uart.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#ifndef BAUD
#  error "BAUD must be given (the Makefile passes 115200 by default)"
#endif

/* Pick normal or double speed, whichever is closer to BAUD, and refuse a
 * baud rate the receiver at the other end may not tolerate: the datasheet's
 * recommended maximum receiver error for 8 data bits is 2.0 % at normal
 * speed and 1.5 % at double speed (U2X). Errors in units of 0.01 %. */
#define UART_UBRR_1X ((F_CPU + 8UL * BAUD) / (16UL * BAUD) - 1UL)
#define UART_UBRR_2X ((F_CPU + 4UL * BAUD) / (8UL * BAUD) - 1UL)
#define UART_REAL_1X (F_CPU / (16UL * (UART_UBRR_1X + 1UL)))
#define UART_REAL_2X (F_CPU / (8UL * (UART_UBRR_2X + 1UL)))
#define UART_ERR(real) ((real) > BAUD ? ((real)-BAUD) * 10000UL / BAUD : (BAUD - (real)) * 10000UL / BAUD)

#if UART_UBRR_1X <= 4095 && UART_ERR(UART_REAL_1X) <= UART_ERR(UART_REAL_2X) && UART_ERR(UART_REAL_1X) <= 200
#  define UART_UBRR UART_UBRR_1X
#  define UART_U2X 0
#elif UART_UBRR_2X <= 4095 && UART_ERR(UART_REAL_2X) <= 150
#  define UART_UBRR UART_UBRR_2X
#  define UART_U2X 1
#else
#  error "BAUD cannot be generated from F_CPU within the USART's error limits (2.0% normal, 1.5% U2X)"
#endif

#define UART_TX_SIZE (UART_STEP_MAX + 1) /* one output step always fits */
#if UART_TX_SIZE - 1 != UART_STEP_MAX
#  error                                                                                                     \
      "the TX ring holds one whole output step, no more (console.c's echo counts on uart_tx_room() <= UART_STEP_MAX)"
#endif

static volatile uint8_t tx_buf[UART_TX_SIZE];
static volatile uint8_t tx_head, tx_tail;
static volatile uint8_t rx_buf[UART_RX_SIZE];
static volatile uint8_t rx_head, rx_tail;
/* Where bytes went missing (0: nowhere; so it starts in .bss): the slot
 * of the byte they went missing before (GAP_SLOT) | GAP_VALID, why
 * (UART_READ_OVERRUN, _FRAME, _RING, shifted down by 8), and GAP_MORE when
 * another gap came before that one and is not yet read: every byte up to
 * the slot then counts as following a gap (a line that lost any byte is
 * refused whole, never glued to the next; a whole line between two gaps
 * may be refused with them). */
static volatile uint8_t rx_gap;
#define GAP_SLOT (UART_RX_SIZE - 1u)
#define GAP_DOR (UART_READ_OVERRUN >> 8) /* UCSR0A's DOR0 bit, as read */
#define GAP_FE (UART_READ_FRAME >> 8)    /* UCSR0A's FE0 bit, as read */
#define GAP_RING (UART_READ_RING >> 8)
#define GAP_MORE 0x20u
#define GAP_VALID 0x80u
#define GAP_WHY (GAP_DOR | GAP_FE | GAP_RING)
#if GAP_DOR != (1 << DOR0) || GAP_FE != (1 << FE0) || GAP_SLOT >= GAP_DOR
#  error                                                                                                     \
      "rx_gap's layout: the slot below DOR0's and FE0's bits, which are the overrun's and the framing error's"
#endif
#if (GAP_WHY | GAP_SLOT) & (GAP_MORE | GAP_VALID) || (UART_READ_EMPTY >> 8) & (GAP_WHY | UART_READ_GAP >> 8)
#  error "rx_gap's bits and uart_read's overlap"
#endif

static uint8_t tx_next(uint8_t i)
{
  return (uint8_t)(i + 1u == UART_TX_SIZE ? 0u : i + 1u);
}

void uart_init(void)
{
  /* U2X before UBRR: the hardware does not mind, and simavr works out the
   * bit time when UBRRL is written, from the U2X bit set at that moment. */
#if UART_U2X
  UCSR0A = (1 << U2X0);
#else
  UCSR0A = 0;
#endif
  UBRR0H = (uint8_t)(UART_UBRR >> 8);
  UBRR0L = (uint8_t)UART_UBRR;
  UCSR0C = (1 << UCSZ01) | (1 << UCSZ00); /* 8N1 */
  UCSR0B = (1 << RXEN0) | (1 << TXEN0) | (1 << RXCIE0);
}

void uart_write(uint8_t c)
{
  uint8_t next = tx_next(tx_head);
  while (next == tx_tail)
    ; /* callers check uart_tx_room() first: this never waits in practice */
  tx_buf[tx_head] = c;
  tx_head = next;
  UCSR0B |= (1 << UDRIE0);
}

uint8_t uart_tx_room(void)
{
  uint8_t h = tx_head, t = tx_tail;
  return (uint8_t)(UART_TX_SIZE - 1u - (h >= t ? h - t : h + UART_TX_SIZE - t));
}

int16_t uart_read(void)
{
  uint8_t c = 0, t = rx_tail, g, hi = 0; /* hi: the UART_READ_* bits, >> 8 */
  ATOMIC_BLOCK(ATOMIC_FORCEON) {
    g = rx_gap;
    if ((uint8_t)((g ^ t) & (GAP_VALID | GAP_SLOT)) == GAP_VALID) { /* bytes were lost just before this one */
      rx_gap = 0;
      hi = (uint8_t)((g & GAP_WHY) | (UART_READ_GAP >> 8));
    } else if (g & GAP_MORE) {
      hi = UART_READ_GAP >> 8; /* an earlier gap, where exactly is not known */
    }
  }
  if (rx_head == t) { /* nothing after the gap yet: the line being received lost bytes */
    if (!hi)
      return -1;
    hi |= UART_READ_EMPTY >> 8;
  } else {
    c = rx_buf[t];
    rx_tail = (uint8_t)((t + 1u) & (UART_RX_SIZE - 1u));
  }
  return (int16_t)((uint16_t)hi << 8 | c);
}

uint8_t uart_rx_pending(void)
{
  return rx_head != rx_tail;
}

ISR(USART_UDRE_vect)
{
  uint8_t t = tx_tail;
  UDR0 = tx_buf[t];
  t = tx_next(t);
  tx_tail = t;
  if (t == tx_head)
    UCSR0B &= (uint8_t) ~(1 << UDRIE0);
}

ISR(USART_RX_vect)
{
  uint8_t h = rx_head;
  /* UCSR0A before UDR0, whose byte its flags describe: DOR0, bytes before
   * this one were lost; FE0, this one came without its stop bit (a bit
   * error on the link): a corrupted byte, lost like them. */
  uint8_t why = UCSR0A & ((1 << DOR0) | (1 << FE0));
  uint8_t c = UDR0;
  uint8_t next = (uint8_t)((h + 1u) & (UART_RX_SIZE - 1u));
  if (next == rx_tail) {
    why |= GAP_RING; /* the next byte stored in slot h follows a gap */
  } else if (!(why & GAP_FE)) {
    rx_buf[h] = c;
    rx_head = next;
  }
  if (why) {
    uint8_t g = rx_gap, other = g ^ h; /* 8-bit steps: no int promotion, fewer registers saved */
    other &= GAP_SLOT;
    if (g && other)
      why |= GAP_MORE;
    g &= (uint8_t)~GAP_SLOT;
    rx_gap = g | why | GAP_VALID | h;
  }
}
