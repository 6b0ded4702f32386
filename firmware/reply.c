/* reply.c - see reply.h. */
#include "reply.h"

#include "adc.h"
#include "command.h"
#include "config.h"
#include "console.h"
#include "link.h"
#include "pgm.h"
#include "proto.h"
#include "settings.h"
#include "vocab.h"

#if CMD_ERR_TIMEOUT > 9
#  error "step_error() writes an error code as one digit"
#endif

static struct {
  uint8_t code; /* REPLY_OK, an error code, REPLY_STATUS or REPLY_HELP */
  uint8_t tail; /* REPLY_TAIL_*; for an error, the command id; for help,
                 * the command of this line, from 0 (CMD_REPORT) */
  union {
    struct {
      const char *text_P;
      union {
        uint32_t n; /* REPLY_TAIL_NUM */
        struct {
          const char *list_P; /* REPLY_TAIL_WORD: word n of this list */
          uint8_t n;
        } word;
      } tail_value;
    };
    char word[REPLY_QUOTE_MAX]; /* error naming no command (CMD_NONE): the line's first word */
  };
} rpl;

void reply_set_error(uint8_t code, uint8_t id, const char *quote, const char *text_P)
{
  rpl.code = code;
  rpl.tail = id;
  if (id == CMD_NONE) {
    /* A copy: the line's buffer takes the next line at once.  A longer
     * word is cut. */
    uint8_t i;
    for (i = 0; i < REPLY_QUOTE_MAX; i++) {
      char c = quote[i];
      if (c == ' ' || c == '\t')
        c = 0;
      rpl.word[i] = c;
      if (!c)
        break;
    }
    return;
  }
  rpl.text_P = text_P;
}

void reply_set(uint8_t code, const char *text_P, uint32_t n)
{
  rpl.code = code;
  rpl.text_P = text_P;
  rpl.tail = REPLY_TAIL_NUM;
  rpl.tail_value.n = n;
}

void reply_set_word(const char *text_P, const char *list_P, uint8_t n)
{
  rpl.code = REPLY_OK;
  rpl.text_P = text_P;
  rpl.tail = REPLY_TAIL_WORD;
  rpl.tail_value.word.list_P = list_P;
  rpl.tail_value.word.n = n;
}

void reply_set_plain(uint8_t code, const char *text_P)
{
  rpl.code = code;
  rpl.text_P = text_P;
  rpl.tail = REPLY_TAIL_NONE; /* help: from the first command */
}

static const char count_P[] PROGMEM = " [count]";
#define REPLY_STR_(x) #x
#define REPLY_STR(x) REPLY_STR_(x)
static const char seconds_P[] PROGMEM = " 0.." REPLY_STR(VOCAB_INTERVAL_MAX_S) " s"; /* vocab.h's limit */
static const char open_P[] PROGMEM = " [";
static const char hz_P[] PROGMEM = " (Hz)";
static const char g_P[] PROGMEM = " (g)";
static const char close_P[] PROGMEM = "]";

/* By argument kind from ARG_COUNT on: the words allowed (a vocab.h
 * list; none for the rates, vocab_rates' numbers), how many, and the text
 * before and after them: help, errors and the parser agree. */
static const struct {
  const char *list, *pre, *post;
  uint8_t count;
} allowed[] PROGMEM = {
    {0, count_P, 0, 0},                   /* ARG_COUNT */
    {0, 0, hz_P, VOCAB_RATE_COUNT},       /* ARG_RATE */
    {0, seconds_P, 0, 0},                 /* ARG_SECONDS */
    {vocab_modes, 0, 0, VOCAB_MODES},     /* ARG_MODE */
    {vocab_ranges, 0, g_P, VOCAB_RANGES}, /* ARG_RANGE */
    {vocab_onoff, open_P, close_P, 2},    /* ARG_ONOFF */
    {vocab_units, open_P, close_P, 2},    /* ARG_UNITS */
};

/* Piece k of the arguments of a command of this kind, as help shows
 * them (" 50|100|...|1000 (Hz)"); in an error (`err`) ";" comes first.
 * Returns 1 after the last piece.  Each piece is at most UART_STEP_MAX
 * characters. */
static __attribute__((noinline)) uint8_t put_allowed(uint8_t kind, uint8_t k, uint8_t err)
{
  const char *list = 0, *pre = 0, *post = 0;
  uint8_t count = 0;
  if (kind == ARG_NONE) {
    pre = err ? PSTR(" no argument") : 0;
  } else {
    kind = (uint8_t)(kind - ARG_COUNT);
    list = (const char *)pgm_read_ptr(&allowed[kind].list);
    pre = (const char *)pgm_read_ptr(&allowed[kind].pre);
    post = (const char *)pgm_read_ptr(&allowed[kind].post);
    count = pgm_read_byte(&allowed[kind].count);
  }
  if (k == 0) {
    if (err)
      proto_putc(';');
    if (pre)
      proto_puts_P(pre);
    else if (count)
      proto_putc(' ');
  } else if (k <= count) {
    if (k > 1)
      proto_putc('|');
    if (list)
      proto_puts_P(vocab_word(list, (uint8_t)(k - 1)));
    else
      proto_u32(pgm_read_word(&vocab_rates[k - 1]));
  } else {
    if (post)
      proto_puts_P(post);
    return 1;
  }
  return 0;
}

/* A line refused before any command is known: two words a code from 1,
 * what is wrong and what is allowed, as reply_set_error's texts (codes 2
 * and 4 always name their command: empty words). */
static const char refused_P[] PROGMEM = "unknown command\0see help\0\0\0line too long\0" REPLY_STR(
    COMMAND_LINE_MAX) " chars\0\0\0"
                      "input lost\0resend\0bad byte\0printable ASCII\0timed out\0resend";
#if CMD_ERR_UNKNOWN != 1 || CMD_ERR_ARG != 2 || CMD_ERR_LONG != 3 || CMD_ERR_STATE != 4 ||                   \
    CMD_ERR_LOST != 5 || CMD_ERR_BYTE != 6 || CMD_ERR_TIMEOUT != 7
#  error "refused_P holds the codes 1..7 in order"
#endif

/* `error:<code> <command>: <what>; <allowed>` */
static __attribute__((noinline)) uint8_t step_error(uint8_t step)
{
  uint8_t none = rpl.tail == CMD_NONE;
  const char *text = none ? vocab_word(refused_P, (uint8_t)(2 * rpl.code - 2)) : rpl.text_P;
  if (step == 0) {
    proto_begin();
    proto_puts_P(PSTR("error:"));
    proto_putc((char)('0' + rpl.code)); /* one digit: command.h's codes */
    proto_putc(' ');
  } else if (step == 1) {
    if (none) {
      uint8_t i;
      for (i = 0; i < REPLY_QUOTE_MAX && rpl.word[i]; i++)
        proto_putc(console_shown_as(rpl.word[i]));
    } else {
      proto_puts_P(command_word(rpl.tail));
    }
    proto_puts_P(PSTR(": "));
  } else if (step == 2) {
    proto_puts_P(text);
  } else {
    text = vocab_word(text, 1);
    if (pgm_read_byte(text)) {
      if (step == 4)
        goto end;
      proto_puts_P(PSTR("; "));
      proto_puts_P(text);
    } else if (put_allowed(command_arg_kind(rpl.tail), (uint8_t)(step - 3), 1)) {
    end:
      proto_end();
      return REPLY_DONE;
    }
  }
  return REPLY_MORE;
}

/* `ok <text>` and the tail. */
static __attribute__((noinline)) uint8_t step_plain(uint8_t step)
{
  switch (step) {
  case 0:
    proto_begin();
    proto_puts_P(PSTR("ok"));
    if (rpl.text_P)
      proto_putc(' ');
    break;
  case 1:
    if (rpl.text_P)
      proto_puts_P(rpl.text_P);
    if (rpl.tail == REPLY_TAIL_NUM)
      proto_u32(rpl.tail_value.n);
    else if (rpl.tail == REPLY_TAIL_WORD)
      proto_puts_P(vocab_word(rpl.tail_value.word.list_P, rpl.tail_value.word.n));
    break;
  default: proto_end(); return REPLY_DONE;
  }
  return REPLY_MORE;
}

/* The settings' keys of `status` and of the report header, in this order
 * (the header has the first SETTINGS_IN_HEADER, after its own fs=). */
static const char setting_keys_P[] PROGMEM = "run\0mode\0range\0units\0cfg\0fs\0interval\0link";
#define SETTING_KEYS 8
#if SETTINGS_IN_HEADER != 5
#  error "the header shows run, mode, range, units and cfg"
#endif

void reply_put_setting(uint8_t k, char sep, uint8_t counts)
{
  uint16_t n;           /* every value fits */
  const char *list = 0; /* a word of this list, at n */
  proto_putc(sep);
  proto_puts_P(vocab_word(setting_keys_P, k));
  proto_putc('=');
  switch (k) {
  case 0: n = adc_running(); break;
  case 1:
    list = vocab_modes;
    n = settings.mode;
    break;
  case 2:
    list = vocab_ranges;
    n = settings.range;
    break;
  case 3:
    list = vocab_units;
    n = counts;
    break;
  case 4:
    list = vocab_sources;
    n = settings_source;
    break;
  case 5: n = adc_rate(); break;
  case 6: n = settings.interval_s; break;
  default: n = link_percent_here(settings.mode, adc_rate()); break;
  }
  if (list)
    proto_puts_P(vocab_word(list, (uint8_t)n));
  else
    proto_u32(n);
}

/* `ok status run= mode= range= units= cfg= fs= interval= link= rx=`: a
 * key=value a step, then rx's counts a step each. */
static __attribute__((noinline)) uint8_t step_status(uint8_t step)
{
  uint8_t k = (uint8_t)(step - 1);
  if (step == 0) {
    proto_begin();
    proto_puts_P(PSTR("ok status"));
  } else if (k < SETTING_KEYS) {
    reply_put_setting(k, ' ', settings.counts);
  } else if ((uint8_t)(k - SETTING_KEYS) < CONSOLE_COUNTS) {
    console_put_count((uint8_t)(k - SETTING_KEYS), ' ');
  } else {
    proto_end();
    return REPLY_DONE;
  }
  return REPLY_MORE;
}

/* `ok help <command><arguments>`, one line per command. */
static __attribute__((noinline)) uint8_t step_help(uint8_t step)
{
  uint8_t id = (uint8_t)(CMD_REPORT + rpl.tail);
  if (step == 0) {
    proto_begin();
    proto_puts_P(PSTR("ok help "));
    proto_puts_P(command_word(id));
  } else if (put_allowed(command_arg_kind(id), (uint8_t)(step - 1), 0)) {
    proto_end();
    return ++rpl.tail < CMD_COUNT ? REPLY_LINE_DONE : REPLY_DONE;
  }
  return REPLY_MORE;
}

/* Each step function returns REPLY_MORE, REPLY_LINE_DONE or REPLY_DONE. */
uint8_t reply_step(uint8_t step)
{
  if (rpl.code == REPLY_HELP)
    return step_help(step);
  if (rpl.code == REPLY_STATUS)
    return step_status(step);
  if (rpl.code != REPLY_OK)
    return step_error(step);
  return step_plain(step);
}
