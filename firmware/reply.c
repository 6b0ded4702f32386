/* reply.c - see reply.h. */
#include "reply.h"

#include "adc.h"
#include "config.h"
#include "link.h"
#include "pgm.h"
#include "proto.h"
#include "settings.h"
#include "vocab.h"

static struct {
  uint8_t code; /* REPLY_OK, an error code, REPLY_STATUS or REPLY_HELP */
  uint8_t tail; /* REPLY_TAIL_* */
  const char *text_P;
  union {
    uint32_t n;         /* REPLY_TAIL_NUM */
    const char *word_P; /* REPLY_TAIL_WORD */
  } tail_value;
} rpl;

void reply_set(uint8_t code, const char *text_P, uint32_t n)
{
  rpl.code = code;
  rpl.text_P = text_P;
  rpl.tail = REPLY_TAIL_NUM;
  rpl.tail_value.n = n;
}

void reply_set_word(const char *text_P, const char *word_P)
{
  rpl.code = REPLY_OK;
  rpl.text_P = text_P;
  rpl.tail = REPLY_TAIL_WORD;
  rpl.tail_value.word_P = word_P;
}

void reply_set_plain(uint8_t code, const char *text_P)
{
  rpl.code = code;
  rpl.text_P = text_P;
  rpl.tail = REPLY_TAIL_NONE;
}

static void put_key_u32(const char *key_P, uint32_t v)
{
  proto_puts_P(key_P);
  proto_u32(v);
}

/* `ok <text>`, `error:<code> <text>`, and the tail. */
static __attribute__((noinline)) uint8_t step_plain(uint8_t step)
{
  switch (step) {
  case 0:
    proto_begin();
    if (rpl.code != REPLY_OK) {
      put_key_u32(PSTR("error:"), rpl.code);
      proto_putc(' ');
    } else {
      proto_puts_P(PSTR("ok"));
      if (rpl.text_P)
        proto_putc(' ');
    }
    break;
  case 1:
    if (rpl.text_P)
      proto_puts_P(rpl.text_P);
    if (rpl.tail == REPLY_TAIL_NUM)
      proto_u32(rpl.tail_value.n);
    else if (rpl.tail == REPLY_TAIL_WORD)
      proto_puts_P(rpl.tail_value.word_P);
    break;
  default:
    proto_end();
    return 1;
  }
  return 0;
}

/* `ok status run= fs= mode= range= interval= link= cfg=` */
static __attribute__((noinline)) uint8_t step_status(uint8_t step)
{
  switch (step) {
  case 0:
    proto_begin();
    proto_puts_P(adc_running() ? PSTR("ok status run=1") : PSTR("ok status run=0"));
    break;
  case 1:
    put_key_u32(PSTR(" fs="), adc_rate());
    proto_puts_P(PSTR(" mode="));
    break;
  case 2:
    proto_puts_P(vocab_word(vocab_modes, settings.mode));
    proto_puts_P(PSTR(" range="));
    proto_puts_P(vocab_word(vocab_ranges, settings.range));
    break;
  case 3:
    put_key_u32(PSTR(" interval="), settings.interval_s);
    break;
  case 4:
    put_key_u32(PSTR(" link="), link_percent(settings.mode, adc_rate(), BAUD));
    proto_puts_P(PSTR(" cfg="));
    break;
  case 5:
    proto_puts_P(vocab_word(vocab_sources, settings_source));
    break;
  default:
    proto_end();
    return 1;
  }
  return 0;
}

static __attribute__((noinline)) uint8_t step_help(uint8_t step)
{
  switch (step) {
  case 0:
    proto_begin();
    proto_puts_P(PSTR("ok help report reset"));
    break;
  case 1: proto_puts_P(PSTR(" stop start rate")); break;
  case 2: proto_puts_P(PSTR(" interval mode range")); break;
  case 3: proto_puts_P(PSTR(" save load defaults")); break;
  case 4: proto_puts_P(PSTR(" status help")); break;
  default:
    proto_end();
    return 1;
  }
  return 0;
}

uint8_t reply_step(uint8_t step)
{
  if (rpl.code == REPLY_STATUS)
    return step_status(step);
  if (rpl.code == REPLY_HELP)
    return step_help(step);
  return step_plain(step);
}
