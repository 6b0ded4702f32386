/* proto.c - see proto.h. */
#include "proto.h"

#include "crc.h"
#include "fmt.h"
#include "pgm.h"

#ifdef __AVR__
#  include "board.h"
#  include "uart.h"
#  define proto_sink uart_write
/* The current line is bound: a flag of board.h's on the device (no SRAM). */
#  define bound_on() (BOARD_FLAGS & BOARD_FLAG_BOUND)
#  define bound_set() (BOARD_FLAGS |= BOARD_FLAG_BOUND)
#  define bound_clear() (BOARD_FLAGS &= (uint8_t)~BOARD_FLAG_BOUND)
#else
static proto_sink_t proto_sink;
static uint8_t proto_bound_on;
#  define bound_on() (proto_bound_on)
#  define bound_set() (proto_bound_on = 1)
#  define bound_clear() (proto_bound_on = 0)
#endif
static uint16_t proto_crc;
static uint16_t proto_bound_crc;

#ifndef __AVR__
void proto_init(proto_sink_t sink)
{
  proto_sink = sink;
}
#endif

void proto_begin(void)
{
  proto_crc = CRC16_INIT;
  bound_clear();
  proto_sink('$');
}

void proto_begin_bound(void)
{
  proto_begin();
  bound_set();
}

void proto_bound_restart(void)
{
  proto_bound_crc = CRC16_MODBUS_INIT;
}

uint16_t proto_bound(void)
{
  return proto_bound_crc;
}

void proto_putc(char c)
{
  /* The framing characters never appear in a body. */
  if (c == '$' || c == '*' || (uint8_t)c < 0x20 || (uint8_t)c > 0x7E)
    c = '?';
  proto_crc = crc16_update(proto_crc, (uint8_t)c);
  if (bound_on())
    proto_bound_crc = crc16_modbus_update(proto_bound_crc, (uint8_t)c);
  proto_sink((uint8_t)c);
}

void proto_puts(const char *s)
{
  while (*s)
    proto_putc(*s++);
}

void proto_puts_P(const char *s)
{
  char c;
  while ((c = (char)pgm_read_byte(s++)) != 0)
    proto_putc(c);
}

void proto_u32(uint32_t v)
{
  char buf[10];
  uint8_t i, n = fmt_u32(buf, v);
  for (i = 0; i < n; i++)
    proto_putc(buf[i]);
}

void proto_hex(uint32_t v, uint8_t digits)
{
  if (digits > 8)
    digits = 8; /* a 32-bit value has 8 */
  while (digits--) {
    uint8_t d = (uint8_t)(v >> (uint8_t)(4u * digits)) & 0xFu;
    proto_putc((char)(d < 10 ? '0' + d : 'A' - 10 + d));
  }
}

void proto_raw(uint8_t c)
{
  proto_sink(c);
}

void proto_end(void)
{
  /* The CRC's digits go through proto_putc (hex digits pass unchanged),
   * outside the bound CRC; the line CRC they update restarts with the
   * next line. */
  uint16_t crc = proto_crc;
  bound_clear();
  proto_sink('*');
  proto_hex(crc, 4);
  proto_sink('\r');
  proto_sink('\n');
}

void proto_frame(uint8_t frame[PROTO_FRAME_BYTES], uint8_t seq)
{
  uint16_t crc = CRC16_INIT;
  uint8_t i;
  frame[0] = PROTO_FRAME_SYNC;
  frame[1] = seq;
  for (i = 1; i < PROTO_FRAME_BYTES - 2; i++)
    crc = crc16_update(crc, frame[i]);
  frame[PROTO_FRAME_BYTES - 2] = (uint8_t)(crc >> 8);
  frame[PROTO_FRAME_BYTES - 1] = (uint8_t)crc;
}
