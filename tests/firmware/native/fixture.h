/*
 * fixture.h - the native test fixture (QMK style): the firmware's real
 * scheduler, producers, control room, settings and engine, compiled for the
 * host, run by the main loop's own body against a fake clock, a fake UART
 * (TX drains and RX arrives at BAUD, 10 bits a byte, through rings of the
 * device's sizes), a fake ADC (ticks at the set rate, the device's ring of
 * two waiting sets, drops counted the device's way) and a fake EEPROM.
 * Each test runs in its own process: every test starts from power-up.
 */
#ifndef FIXTURE_H
#define FIXTURE_H

#include <stddef.h>
#include <stdint.h>

/* Power-up, as main() does it, with the given MCUSR bits. */
void fx_boot(uint8_t mcusr);

/* Let `us` microseconds of device time pass, the loop running throughout. */
void fx_run_us(uint64_t us);

/* Bytes to the device's RX pin, from now on, one every byte time. */
void fx_send(const char *bytes, size_t n);
void fx_send_str(const char *s);

/* Bytes sent that the USART loses (a data overrun: the loop kept its
 * interrupt away): the byte after them comes with DOR set. */
void fx_send_overrun(const char *bytes, size_t n);

/* Bytes sent that arrive with a framing error (FE: a bit error on the
 * link): the USART flags each, and the device throws it away. */
void fx_send_frame_error(const char *bytes, size_t n);

/* Everything the device wrote, in order (NUL-terminated copy too). */
extern char fx_out[1 << 20];
extern size_t fx_out_len;

/* The ADC code of column col of the i-th set the fake ADC produced (0-based,
 * counted from power-up). */
uint16_t fx_code(uint32_t i, uint8_t col);
/* Sets produced so far, and sets the fake ADC dropped (ring full). */
extern uint32_t fx_sets_made;

/* Device time in microseconds. */
uint64_t fx_now_us(void);

/* The n-th (0-based) framed line `$...*XXXX` of the output whose body
 * starts with prefix, into body (without `$` and `*XXXX`), its CRC field
 * into *crc; returns the offset of its `$` in fx_out, or -1. */
long fx_find_line(const char *prefix, unsigned n, char *body, size_t body_size, unsigned *crc);

/* How many framed lines start with prefix. */
unsigned fx_count_lines(const char *prefix);

#endif
