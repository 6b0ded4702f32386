/*
 * control.c - see control.h.  Commands run only where their reply may be
 * written at once (switchboard_can_interject), so a reply never cuts into a line.
 */
#include "control.h"

#include "adc.h"
#include "board.h"
#include "command.h"
#include "config.h"
#include "console.h"
#include "link.h"
#include "pgm.h"
#include "proto.h"
#include "sample.h"
#include "settings.h"
#include "stream.h"
#include "switchboard.h"
#include "uart.h"
#include "vocab.h"

/* Every set sampled so far that the stream no longer holds, to the
 * engine (stop, start and reset must see them): the main loop's order
 * (loop.c), without its receiving. */
static void feed(void)
{
  while (adc_pending() && !stream_holds_oldest()) {
    sample_take();
    stream_taken();
  }
}

/* MMA7260Q g-select pins: GS1 = bit 0, GS2 = bit 1 of the range code. */
static void range_pins(uint8_t range)
{
  uint8_t port = BOARD_GSEL_PORT & (uint8_t) ~((1 << BOARD_GSEL1_BIT) | (1 << BOARD_GSEL2_BIT));
  if (range & 1u)
    port |= (1 << BOARD_GSEL1_BIT);
  if (range & 2u)
    port |= (1 << BOARD_GSEL2_BIT);
  BOARD_GSEL_PORT = port;
}

/* A new run: the accumulators, counters and row count start again.  A
 * report being written would now mix two runs: it is cut off. */
static void new_run(void)
{
  switchboard_new_run();
  sample_reset();
  sample_interval_restart();
  switchboard_restart_rows();
}

/* The settings' rate and range in force, and a new run. */
static __attribute__((noinline)) void put_in_force(void)
{
  adc_set_rate(settings.rate_hz);
  range_pins(settings.range);
  new_run();
}

/* Sets sampled so far: those the engine holds and those waiting for it. */
static __attribute__((noinline)) uint32_t sets_taken(void)
{
  return sample_engine.n + adc_pending();
}

/* The `count` of a `start <count>` still running (the engine's n when it
 * stops), or 0. */
static uint32_t count_in_force(void)
{
  uint32_t left = adc_remaining();
  if (left == ADC_UNLIMITED || !adc_running())
    return 0;
  return sets_taken() + left;
}

/* Put the settings in force; a different rate or range starts a new run
 * (results from mixed settings would be meaningless), which keeps a
 * `start <count>`: it stops at n = count.  Returns 1 if so. */
static uint8_t apply_settings(void)
{
  /* In force: the timer's rate and the g-select pins (no copy kept). */
  uint8_t port = BOARD_GSEL_PORT;
  uint8_t range = (uint8_t)(((port >> BOARD_GSEL1_BIT) & 1u) | ((port >> BOARD_GSEL2_BIT) & 1u) << 1);
  uint8_t changed = settings.rate_hz != adc_rate() || settings.range != range;
  if (changed) {
    uint8_t was_running = adc_running();
    uint32_t count = count_in_force();
    adc_stop();
    adc_flush(); /* sets taken under the old settings go with the old run */
    put_in_force();
    if (was_running)
      adc_start(count != 0, count);
  }
  return changed;
}

void control_init(void)
{
  settings_load();
  BOARD_GSEL_DDR |= (1 << BOARD_GSEL1_BIT) | (1 << BOARD_GSEL2_BIT);
  put_in_force();
}

/* `start [count]`: with a count, stop by itself when the engine holds
 * count sets. */
static void run_start(const command_t *cmd)
{
  uint32_t have = 0; /* without a count, arg is 0: adc_start(0, 0) */
  feed();
  if (cmd->has_arg)
    have = sets_taken();
  if (cmd->arg < have) {
    switchboard_error(CMD_ERR_ARG, CMD_START, PSTR("count too small\0above n"));
    return;
  }
  adc_start(cmd->has_arg, cmd->arg - have);
  switchboard_ok(PSTR("started"));
}

/* Replies that share their ends: "rate=" is reset_rate_P + 6; "loaded"
 * and "defaults" end with word 1 of reset_tail_P (" reset") when they
 * reset, word 0 ("") when not, and "reset" is reset_tail_P + 2. */
static const char reset_rate_P[] PROGMEM = "reset rate=";
static const char reset_range_P[] PROGMEM = "reset range=";
static const char reset_tail_P[] PROGMEM = "\0 reset";

/* switchboard_error()'s texts: what is wrong, what is allowed. */
static const char link_slow_P[] PROGMEM = "link too slow\0lower rate";

/* `rate`, `mode`: refused when the link cannot carry the mode's output. */
static void run_rate(uint32_t hz)
{
  if (!vocab_rate_ok(hz)) {
    switchboard_error(CMD_ERR_ARG, CMD_RATE, PSTR("unsupported\0"));
  } else if (!link_fits_here(settings.mode, (uint16_t)hz)) {
    switchboard_error(CMD_ERR_STATE, CMD_RATE, link_slow_P);
  } else {
    settings.rate_hz = (uint16_t)hz;
    switchboard_ok_n(reset_rate_P + (apply_settings() ? 0 : 6), hz);
  }
}

static void run_mode(uint8_t mode)
{
  if (!link_fits_here(mode, settings.rate_hz)) {
    switchboard_error(CMD_ERR_STATE, CMD_MODE, link_slow_P);
    return;
  }
  if (mode == MODE_RAW || mode == MODE_BINARY)
    switchboard_abort_report(); /* no reports in these modes */
  settings.mode = mode;
  switchboard_restart_rows();
  switchboard_ok_word(PSTR("mode="), vocab_modes, mode);
}

static __attribute__((noinline)) void run_load(void)
{
  settings_t before = settings; /* its source too */
  uint8_t loaded = settings_load();
  if (loaded != CFG_SAVED) {
    settings = before; /* nothing usable saved: keep what is in force */
    switchboard_error(CMD_ERR_STATE, CMD_LOAD,
                      loaded == CFG_INFEASIBLE ? link_slow_P : PSTR("nothing saved\0save first"));
    return;
  }
  switchboard_ok_word(PSTR("loaded"), reset_tail_P, apply_settings());
}

static void run_report(void)
{
  if (settings.mode == MODE_RAW || settings.mode == MODE_BINARY) {
    switchboard_error(CMD_ERR_STATE, CMD_REPORT, PSTR("none in this mode\0allan or both"));
    return;
  }
  switchboard_ok(0);
  switchboard_report(); /* follows the reply */
}

static void run_reset(void)
{
  uint32_t count;
  feed(); /* sets taken so far belong to the old run */
  count = count_in_force();
  new_run();
  if (count)
    adc_limit(count); /* `start <count>` stops at n = count in the new run */
  switchboard_ok(reset_tail_P + 2);
}

static void run_interval(uint32_t s)
{
  if (s > VOCAB_INTERVAL_MAX_S) {
    switchboard_error(CMD_ERR_ARG, CMD_INTERVAL, PSTR("too long\0"));
    return;
  }
  settings.interval_s = (uint16_t)s;
  switchboard_ok_n(PSTR("interval="), s);
}

static void execute(const command_t *cmd)
{
  switch (cmd->id) {
  case CMD_REPORT: run_report(); break;
  case CMD_RESET: run_reset(); break;
  case CMD_STOP:
    adc_stop();
    feed();
    switchboard_ok_n(PSTR("stopped n="), sample_engine.n);
    break;
  case CMD_START: run_start(cmd); break;
  case CMD_RATE: run_rate(cmd->arg); break;
  case CMD_INTERVAL: run_interval(cmd->arg); break;
  case CMD_MODE: run_mode((uint8_t)cmd->arg); break;
  case CMD_RANGE:
    settings.range = (uint8_t)cmd->arg;
    switchboard_ok_word(reset_range_P + (apply_settings() ? 0 : 6), vocab_ranges, settings.range);
    break;
  case CMD_SAVE: settings_save(); break; /* replied when the last byte is written */
  case CMD_LOAD: run_load(); break;
  case CMD_DEFAULTS:
    settings_defaults();
    switchboard_ok_word(vocab_word(vocab_sources, CFG_DEFAULTS), reset_tail_P, apply_settings());
    break;
  case CMD_STATUS: switchboard_status(); break;
  case CMD_ECHO:
    if (cmd->has_arg)
      settings.echo = (uint8_t)cmd->arg;
    switchboard_ok_word(PSTR("echo="), vocab_onoff, settings.echo);
    break;
  case CMD_UNITS: /* of the summary (report.c): the next report's */
    if (cmd->has_arg)
      settings.counts = (uint8_t)cmd->arg;
    switchboard_ok_word(PSTR("units="), vocab_units, settings.counts);
    break;
  default: /* CMD_HELP */ switchboard_help(); break;
  }
}

/* Run the waiting command line (replies: docs/protocol.md). */
static __attribute__((noinline)) void run_line(void)
{
  command_t cmd;
  const char *text;
  uint8_t err = console_take(&text);
  if (!err)
    err = command_parse(text, &cmd);
  if (err == CMD_ERR_ARG)
    switchboard_error(err, cmd.id, PSTR("bad argument\0"));
  else if (err)
    switchboard_refuse(err, text);
  else if (cmd.id != CMD_NONE)
    execute(&cmd);
}

/* Kept apart from the console's work, and small: a command may feed the
 * engine (stop, start, reset), the deepest stack there is.  A complete
 * line runs when the output is between two lines (and no EEPROM save is
 * under way), so its reply never cuts into a line; the rest of its echo
 * goes just before the reply. */
static void poll_commands(void)
{
  /* Typed characters are echoed as they come in mode allan, nothing else
   * being written; otherwise a line's echo goes out whole just before its
   * reply (a raw row waits for it as for a reply: link.h). */
  console_poll(settings.mode == MODE_ALLAN && !switchboard_busy());
  if (console_ready() && switchboard_can_interject() && !settings_saving()) {
    if (settings.echo)
      switchboard_echo(); /* the reply follows it */
    run_line();
  }
}

void control_poll(void)
{
  /* EEPROM bytes go out only where the reply may follow at once. */
  if (settings_saving() && switchboard_can_interject() && console_close() && settings_poll())
    switchboard_ok(vocab_sources); /* "saved": the first word, CFG_SAVED */
  poll_commands();
  /* A periodic report never waits on a half-typed line: an echo line on
   * the screen is ended first, and shown again after the report. */
  if (settings.interval_s && settings.mode != MODE_RAW && settings.mode != MODE_BINARY &&
      !settings_saving() && !switchboard_busy() &&
      sample_stats.since_report >= (uint32_t)settings.interval_s * settings.rate_hz && console_close())
    switchboard_report(); /* its header restarts the interval */
}

uint8_t control_has_work(void)
{
  return uart_rx_pending() || settings_saving() || console_ready();
}
