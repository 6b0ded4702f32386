/*
 * uart.h - interrupt-driven serial port with small TX and RX rings.
 */
#ifndef UART_H
#define UART_H

#include <stdint.h>

#include "config.h" /* UART_STEP_MAX, UART_RX_SIZE */

void uart_init(void);

/* Queue one byte; waits while the TX ring is full, so callers first check
 * uart_tx_room() (the output scheduler writes only what fits). */
void uart_write(uint8_t c);

/* Bytes the TX ring can take now: at most UART_STEP_MAX (the ring holds
 * one whole step, no more). */
uint8_t uart_tx_room(void);

/* Next received byte, or -1 when none is waiting.  UART_READ_GAP is or-ed
 * in when bytes were lost just before this one, every time it happens, so
 * that the line they belonged to is refused whole instead of run cut short
 * or glued to the next; with it, why: UART_READ_OVERRUN (a data overrun in
 * the USART: the RX interrupt was kept away for two byte times),
 * UART_READ_FRAME (a framing error: a corrupted byte, thrown away) and/or
 * UART_READ_RING (the RX ring was full), once per gap (none when several
 * gaps came and this byte only follows an earlier one).  A gap with no
 * byte after it yet comes alone, with UART_READ_EMPTY: the line being
 * received lost its end.  OVERRUN and FRAME are UCSR0A's DOR0 and FE0
 * bits, shifted up by 8. */
#define UART_READ_GAP 0x100
#define UART_READ_OVERRUN 0x0800
#define UART_READ_FRAME 0x1000
#define UART_READ_EMPTY 0x2000
#define UART_READ_RING 0x4000
int16_t uart_read(void);

/* 1 when a received byte waits in the RX ring. */
uint8_t uart_rx_pending(void);

#endif /* UART_H */
