/*
 * uart.h - interrupt-driven serial port with small TX and RX rings.
 */
#ifndef UART_H
#define UART_H

#include <stdint.h>

/* idle: called while uart_write waits for room in the TX ring, so the main
 * loop keeps feeding the Allan engine while a report drains. */
void uart_init(void (*idle)(void));

/* Queue one byte; waits (running idle) while the TX ring is full. */
void uart_write(uint8_t c);

/* Next received byte, or -1 when none is waiting. */
int16_t uart_read(void);

/* 1 when a received byte waits in the RX ring. */
uint8_t uart_rx_pending(void);

/* Bytes lost because the RX ring was full (since boot, saturating). */
uint8_t uart_rx_overruns(void);

/* 1 while bytes are still queued or being shifted out. */
uint8_t uart_tx_busy(void);

#endif /* UART_H */
