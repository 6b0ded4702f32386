/* stream.c - see stream.h. */
#include "stream.h"

#include "adc.h"
#include "board.h"
#include "crc.h"
#include "fmt.h"
#include "link.h"
#include "pgm.h"
#include "proto.h"
#include "settings.h"
#include "vocab.h"

/* Where the stream's own line stands. */
enum {
  LINE_NONE,       /* between lines */
  LINE_ROW_HALF,   /* a raw row's first half is written */
  LINE_COUNT_DUE,  /* a count line waits for a line boundary */
  LINE_COUNT_HALF, /* a count line's rows are written */
  LINE_COUNT_LAST  /* a count line's drops are written */
};

static struct {
  uint8_t line;  /* LINE_* */
  uint16_t crc;  /* CRC-16/MODBUS of the rows or frames since the last count line */
  uint32_t rows; /* rows or frames written since stream_restart() */
} st;
/* The oldest set's row or frame is written: a flag of board.h's (no SRAM). */
#define SET_DONE (BOARD_FLAGS & BOARD_FLAG_SET_DONE)
#define set_done(on)                                                                                         \
  ((on) ? (BOARD_FLAGS |= BOARD_FLAG_SET_DONE) : (BOARD_FLAGS &= (uint8_t)~BOARD_FLAG_SET_DONE))

/* Every row or frame byte goes out here, into the count line's CRC. */
static void put(uint8_t c)
{
  st.crc = crc16_modbus_update(st.crc, c);
  proto_raw(c);
}

void stream_restart(void)
{
  st.line = LINE_NONE;
  set_done(0);
  st.rows = 0;
  st.crc = CRC16_MODBUS_INIT;
}

uint8_t stream_holds_oldest(void)
{
  if (settings.mode == MODE_ALLAN)
    return 0;
  return (uint8_t)(~BOARD_FLAGS & BOARD_FLAG_SET_DONE); /* not 0 until written */
}

void stream_taken(void)
{
  set_done(0);
}

uint8_t stream_line_open(void)
{
  return st.line == LINE_ROW_HALF || st.line >= LINE_COUNT_HALF;
}

uint8_t stream_busy(void)
{
  return st.line != LINE_NONE;
}

/* A row or frame is out: count it, and a count line is due every
 * LINK_COUNT_EVERY of them (one already due stays due: a frame may come
 * before it). */
static void set_written(void)
{
  set_done(1);
  st.rows++;
  if (st.rows % LINK_COUNT_EVERY == 0)
    st.line = LINE_COUNT_DUE;
  else if (st.line == LINE_ROW_HALF)
    st.line = LINE_NONE;
}

/* The step functions below return 1 (they wrote), stream_step's result. */

/* `$C,<rows>,<drops>,<crc>` in three steps; the CRC restarts after it. */
static __attribute__((noinline)) uint8_t step_count_line(void)
{
  if (st.line == LINE_COUNT_DUE) {
    proto_begin();
    proto_puts_P(PSTR("C,"));
    proto_u32(st.rows);
    st.line = LINE_COUNT_HALF;
  } else if (st.line == LINE_COUNT_HALF) {
    proto_putc(',');
    proto_u32(adc_drops());
    st.line = LINE_COUNT_LAST;
  } else {
    proto_putc(',');
    proto_hex(st.crc, 4);
    proto_end();
    st.crc = CRC16_MODBUS_INIT;
    st.line = LINE_NONE;
  }
  return 1;
}

/* A raw thesis row of the oldest set, in two steps of at most 20
 * characters: codes 0..3, then 4..6 and the line end. */
static __attribute__((noinline)) uint8_t step_raw_row(void)
{
  char buf[10];
  uint8_t second = st.line == LINE_ROW_HALF;
  uint8_t i = second ? 4 : 0, end = second ? ADC_COLUMNS : 4;
  for (; i < end; i++) {
    uint8_t j, n = fmt_u32(buf, adc_oldest(i));
    for (j = 0; j < n; j++)
      put((uint8_t)buf[j]);
    put(i + 1 < ADC_COLUMNS ? '\t' : '\r');
  }
  if (!second) {
    st.line = LINE_ROW_HALF;
    return 1;
  }
  put('\n');
  set_written();
  return 1;
}

/* One 13-byte binary frame of the oldest set; its sequence number is the
 * low byte of the frame count. */
static __attribute__((noinline)) uint8_t step_frame(void)
{
  uint8_t b[PROTO_FRAME_BYTES], i;
  adc_peek_packed(b + 2); /* the payload lands where the frame wants it */
  proto_frame(b, (uint8_t)st.rows);
  for (i = 0; i < PROTO_FRAME_BYTES; i++)
    put(b[i]);
  set_written();
  return 1;
}

uint8_t stream_step(uint8_t at_boundary, uint8_t held)
{
  if (st.line == LINE_ROW_HALF)
    return step_raw_row();
  if (st.line >= LINE_COUNT_HALF || (st.line == LINE_COUNT_DUE && at_boundary))
    return step_count_line();
  if (settings.mode == MODE_ALLAN || SET_DONE || held || !adc_pending())
    return 0;
  if (settings.mode == MODE_BINARY)
    return step_frame();
  if (st.line == LINE_NONE && at_boundary)
    return step_raw_row();
  return 0;
}
