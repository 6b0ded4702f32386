/*
 * proto.h - encoder of protocol lines (docs/protocol.md):
 *     $<body>*<CRC16 hex>\r\n
 * Characters go straight to a sink (the UART on the device, a buffer in
 * tests) while the CRC runs, so no line buffer is needed.
 */
#ifndef PROTO_H
#define PROTO_H

#include <stdint.h>

typedef void (*proto_sink_t)(uint8_t c);

#ifdef __AVR__
/* On the device every line goes to the UART (uart_write): no pointer kept
 * in RAM, whose every byte is the stack's. */
#  define proto_init(sink) ((void)(sink))
#else
void proto_init(proto_sink_t sink);
#endif
void proto_begin(void); /* '$', CRC restarts */

/* A line whose body also goes into the bound CRC (CRC-16/MODBUS over the
 * bodies of every such line since proto_bound_restart()): a report's H
 * and L lines, checked again by its V line. */
void proto_begin_bound(void);
void proto_bound_restart(void);
uint16_t proto_bound(void);
void proto_putc(char c);                    /* one body character */
void proto_puts(const char *s);             /* body text from RAM */
void proto_puts_P(const char *s);           /* body text from flash (PSTR) */
void proto_u32(uint32_t v);                 /* decimal */
void proto_hex(uint32_t v, uint8_t digits); /* digits: 0..8 */
void proto_end(void);                       /* '*', CRC, CR LF */

/* One byte outside any line (raw rows, binary frames), straight to the
 * sink: no escaping, no CRC. */
void proto_raw(uint8_t c);

/* Binary frame (docs/protocol.md): sync, sequence number, the 9 packed
 * bytes of one sample set, CRC-16 of bytes 1..10, high byte first. */
#define PROTO_FRAME_SYNC 0xA5
#define PROTO_FRAME_PAYLOAD 9
#define PROTO_FRAME_BYTES 13
/* The frame around the payload the caller has put at frame + 2. */
void proto_frame(uint8_t frame[PROTO_FRAME_BYTES], uint8_t seq);

#endif /* PROTO_H */
