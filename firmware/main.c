/*
 * main.c - imu-allan firmware: sample the IMU, feed the Allan engine,
 * answer commands and send reports.  Interrupts fill rings; everything
 * else happens in the loop below, which never waits on the UART.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <avr/sleep.h>

#include "adc.h"
#include "board.h"
#include "command.h"
#include "config.h"
#include "link.h"
#include "proto.h"
#include "report.h"
#include "reset.h"
#include "sample.h"
#include "settings.h"
#include "uart.h"

/* The command line being received; `ready` holds a complete one until the
 * output is between two lines, so a reply never cuts into another line. */
static struct {
  char text[COMMAND_LINE_MAX + 1];
  uint8_t len;
  uint8_t overflow; /* LINE_LONG, LINE_LOST: the line is thrown away at its end */
  uint8_t ready;
} line;
#define LINE_LONG 1
#define LINE_LOST 2

static const char reply_mode[4][12] PROGMEM = {"mode=allan", "mode=raw", "mode=binary", "mode=both"};
static const char reply_range[4][10] PROGMEM = {"range=1.5", "range=2", "range=4", "range=6"};
static const char reply_range_reset[4][16] PROGMEM = {"reset range=1.5", "reset range=2",
                                                     "reset range=4", "reset range=6"};

static void uart_sink(uint8_t c)
{
  uart_write(c);
}

/* MMA7260Q g-select pins: GS1 = bit 0, GS2 = bit 1 of the range code. */
static void apply_range(uint8_t range)
{
  uint8_t port = BOARD_GSEL_PORT & (uint8_t)~((1 << BOARD_GSEL1_BIT) | (1 << BOARD_GSEL2_BIT));
  if (range & 1u)
    port |= (1 << BOARD_GSEL1_BIT);
  if (range & 2u)
    port |= (1 << BOARD_GSEL2_BIT);
  BOARD_GSEL_PORT = port;
}

static void stop_sampling(void)
{
  adc_stop();
  sample_pump();
}

/* A new run: the accumulators, counters and row count start again.  A
 * report being written would now mix two runs: it is cut off. */
static void new_run(void)
{
  report_abort();
  sample_reset();
  sample_interval_restart();
  report_restart_rows();
}

/* Put the settings in force; a different rate or range starts a new run
 * (results from mixed settings would be meaningless).  Returns 1 if so. */
static uint8_t apply_settings(uint16_t old_rate, uint8_t old_range)
{
  uint8_t changed = settings.rate_hz != old_rate || settings.range != old_range;
  if (changed) {
    uint8_t was_running = adc_running();
    adc_stop();
    adc_flush(); /* sets taken under the old settings go with the old run */
    adc_set_rate(settings.rate_hz);
    apply_range(settings.range);
    new_run();
    if (was_running)
      adc_start(0, 0);
  }
  return changed;
}

static void execute(const command_t *cmd)
{
  uint16_t old_rate = settings.rate_hz;
  uint8_t old_range = settings.range;

  switch (cmd->id) {
  case CMD_REPORT:
    if (settings.mode == MODE_RAW || settings.mode == MODE_BINARY) {
      report_error(CMD_ERR_STATE, PSTR("no reports in this mode"));
      break;
    }
    report_ok(0);
    report_start(); /* follows the reply */
    break;
  case CMD_RESET:
    sample_pump();
    new_run();
    report_ok(PSTR("reset"));
    break;
  case CMD_STOP:
    stop_sampling();
    report_ok_n(PSTR("stopped n="), sample_engine.n);
    break;
  case CMD_START:
    sample_pump();
    if (cmd->has_arg) {
      /* `start <count>`: stop by itself when the engine holds count sets */
      uint32_t have = sample_engine.n + adc_pending();
      if (cmd->arg < have) {
        report_error(CMD_ERR_ARG, PSTR("count too small"));
        break;
      }
      adc_start(1, cmd->arg - have);
    } else {
      adc_start(0, 0);
    }
    report_ok(PSTR("started"));
    break;
  case CMD_RATE:
    if (!command_rate_ok(cmd->arg)) {
      report_error(CMD_ERR_ARG, PSTR("unsupported rate"));
    } else if (!link_fits(settings.mode, (uint16_t)cmd->arg, BAUD)) {
      report_error(CMD_ERR_STATE, PSTR("link too slow"));
    } else {
      settings.rate_hz = (uint16_t)cmd->arg;
      report_ok_n(apply_settings(old_rate, old_range) ? PSTR("reset rate=") : PSTR("rate="), cmd->arg);
    }
    break;
  case CMD_INTERVAL:
    if (cmd->arg > 3600) {
      report_error(CMD_ERR_ARG, PSTR("interval 0..3600"));
    } else {
      settings.interval_s = (uint16_t)cmd->arg;
      report_ok_n(PSTR("interval="), cmd->arg);
    }
    break;
  case CMD_MODE:
    if (!link_fits((uint8_t)cmd->arg, settings.rate_hz, BAUD)) {
      report_error(CMD_ERR_STATE, PSTR("link too slow"));
    } else {
      if (cmd->arg == MODE_RAW || cmd->arg == MODE_BINARY)
        report_abort(); /* no reports in these modes */
      settings.mode = (uint8_t)cmd->arg;
      report_restart_rows();
      report_ok(reply_mode[cmd->arg]);
    }
    break;
  case CMD_RANGE:
    settings.range = (uint8_t)cmd->arg;
    report_ok(apply_settings(old_rate, old_range) ? reply_range_reset[cmd->arg] : reply_range[cmd->arg]);
    break;
  case CMD_SAVE:
    settings_save(); /* replied when the last byte is written */
    break;
  case CMD_LOAD: {
    settings_t before = settings;
    uint8_t source = settings_source;
    if (settings_load() != CFG_SAVED) {
      settings = before; /* nothing valid saved: keep what is in force */
      settings_source = source;
      report_error(CMD_ERR_STATE, PSTR("nothing saved"));
      break;
    }
    report_ok(apply_settings(old_rate, old_range) ? PSTR("loaded reset") : PSTR("loaded"));
    break;
  }
  case CMD_DEFAULTS:
    settings_defaults();
    report_ok(apply_settings(old_rate, old_range) ? PSTR("defaults reset") : PSTR("defaults"));
    break;
  case CMD_STATUS:
    report_status();
    break;
  case CMD_HELP:
    report_help();
    break;
  default:
    report_error(CMD_ERR_UNKNOWN, PSTR("unknown command"));
    break;
  }
}

static __attribute__((noinline)) void run_line(void)
{
  command_t cmd;
  uint8_t err;
  line.ready = 0;
  if (line.overflow) {
    if (line.overflow & LINE_LOST)
      report_error(CMD_ERR_LOST, PSTR("input lost"));
    else
      report_error(CMD_ERR_LONG, PSTR("line too long"));
    line.overflow = 0;
    return;
  }
  err = command_parse(line.text, &cmd);
  if (err == CMD_ERR_UNKNOWN)
    report_error(err, PSTR("unknown command"));
  else if (err)
    report_error(err, PSTR("bad argument"));
  else if (cmd.id != CMD_NONE)
    execute(&cmd);
}

/* Assemble command lines from the RX ring; run each when the output is
 * between two lines (and no EEPROM save is under way). */
static __attribute__((noinline)) void poll_commands(void)
{
  int16_t c;
  while (!line.ready && (c = uart_read()) >= 0) {
    if (c & UART_READ_GAP) {
      line.overflow |= LINE_LOST; /* never run a line with bytes missing */
      c &= 0xFF;
    }
    if (c == '\r' || c == '\n') {
      line.text[line.len] = 0;
      line.ready = line.len || line.overflow; /* blank lines are ignored */
      line.len = 0;
    } else if (line.len < COMMAND_LINE_MAX) {
      line.text[line.len++] = (char)c;
    } else {
      line.overflow |= LINE_LONG; /* discard the whole line at its end */
    }
  }
  if (line.ready && report_can_interject() && !settings_saving())
    run_line();
}

/* Work the loop can do right now; without any, it sleeps until an
 * interrupt (a tick, a conversion, a byte in or out) brings some. */
static uint8_t has_work(void)
{
  uint8_t can_write = uart_tx_room() >= REPORT_STEP_MAX;
  if (adc_pending() && (!report_holds_sample() || can_write))
    return 1; /* a set to feed to the engine, or its row or frame to write */
  return uart_rx_pending() || settings_saving() || (report_busy() && can_write);
}

/* main never returns: OS_main spares it saving registers on the stack. */
int main(void) __attribute__((OS_main));
int main(void)
{
  report_init(reset_cause());
  proto_init(uart_sink);
  uart_init();
  adc_init();
  settings_load();
  BOARD_GSEL_DDR |= (1 << BOARD_GSEL1_BIT) | (1 << BOARD_GSEL2_BIT);
  apply_range(settings.range);
  adc_set_rate(settings.rate_hz);
  new_run();
  set_sleep_mode(SLEEP_MODE_IDLE);
  reset_watchdog_start();
  sei();

  report_boot();
  adc_start(0, 0);
  for (;;) {
    reset_watchdog_kick();
    sample_pump();
    report_poll();
    /* EEPROM bytes go out only where the reply may follow at once. */
    if (settings_saving() && report_can_interject() && settings_poll())
      report_ok(PSTR("saved"));
    poll_commands();
    if (settings.interval_s && settings.mode != MODE_RAW && settings.mode != MODE_BINARY && !settings_saving() &&
        !report_busy() && sample_stats.since_report >= (uint32_t)settings.interval_s * settings.rate_hz)
      report_start(); /* its header restarts the interval */
    /* Sleep until the next interrupt unless there is work to do now. */
    cli();
    if (!has_work()) {
      sleep_enable();
      sei();
      sleep_cpu();
      sleep_disable();
    }
    sei();
  }
}
