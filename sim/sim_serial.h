/*
 * sim_serial.h - the device's UART seen from the host, both ways.  Host
 * bytes queue here and reach the device one byte time apart; device bytes
 * go to h->on_byte, and each framed protocol line, its CRC checked, to
 * h->on_line.
 */
#ifndef SIM_SERIAL_H
#define SIM_SERIAL_H

#include <stddef.h>
#include <stdint.h>

#include "harness.h"

void serial_connect(harness_t *h);                  /* hooks the UART's IRQs */
avr_cycle_count_t serial_byte_cycles(harness_t *h); /* one byte on the wire */
void serial_push(harness_t *h, const uint8_t *b, size_t n);
/* A harness command: closes an open user line first, ends with CR. */
void serial_send_cmd(harness_t *h, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
void serial_send_user(harness_t *h, const uart_in_t *u);
size_t serial_queued(const harness_t *h); /* host bytes not yet sent */
/* Forget the queued host bytes (a closed terminal, a reset); how many. */
size_t serial_drop_queued(harness_t *h);
/* After an MCU reset: simavr dropped the cycle timers, the wire is idle. */
void serial_after_reset(harness_t *h);

#endif /* SIM_SERIAL_H */
