/*
 * main.c - imu-allan firmware: sample the IMU, feed the Allan engine,
 * answer commands and send reports.  Interrupts fill rings; everything
 * else happens in the loop below, which never waits on the UART.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <avr/sleep.h>
#include <avr/wdt.h>

#include "adc.h"
#include "command.h"
#include "config.h"
#include "proto.h"
#include "report.h"
#include "sample.h"
#include "uart.h"

/* MCUSR must be read before anything clears it (avr-libc's recipe). */
static uint8_t main_mcusr __attribute__((section(".noinit")));
void main_get_mcusr(void) __attribute__((naked, used, section(".init3")));
void main_get_mcusr(void)
{
  main_mcusr = MCUSR;
  MCUSR = 0;
  wdt_disable();
}

/* The command line being received; `ready` holds a complete one until no
 * output job is running, so a reply never cuts into a report. */
static struct {
  char text[COMMAND_LINE_MAX + 1];
  uint8_t len;
  uint8_t overflow;
  uint8_t ready;
} line;

static void uart_sink(uint8_t c)
{
  uart_write(c);
}

static void stop_sampling(void)
{
  adc_stop();
  sample_pump();
}

static void execute(const command_t *cmd)
{
  switch (cmd->id) {
  case CMD_REPORT:
    report_ok(0);
    report_start(); /* follows the reply */
    break;
  case CMD_RESET:
    sample_pump();
    sample_reset();
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
      break;
    }
    {
      uint8_t was_running = adc_running();
      stop_sampling();
      adc_set_rate((uint16_t)cmd->arg);
      sample_reset(); /* results from two rates would be meaningless */
      sample_interval_restart();
      if (was_running)
        adc_start(0, 0);
    }
    report_ok_n(PSTR("reset rate="), cmd->arg);
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
    line.overflow = 0;
    report_error(CMD_ERR_LONG, PSTR("line too long"));
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

/* Assemble command lines from the RX ring; run each when output is idle. */
static __attribute__((noinline)) void poll_commands(void)
{
  int16_t c;
  while (!line.ready && (c = uart_read()) >= 0) {
    if (c == '\r' || c == '\n') {
      line.text[line.len] = 0;
      line.ready = line.len || line.overflow; /* blank lines are ignored */
      line.len = 0;
    } else if (line.len < COMMAND_LINE_MAX) {
      line.text[line.len++] = (char)c;
    } else {
      line.overflow = 1; /* discard the whole line at its end */
    }
  }
  if (line.ready && !report_busy())
    run_line();
}

/* main never returns: OS_main spares it saving registers on the stack. */
int main(void) __attribute__((OS_main));
int main(void)
{
  report_init(main_mcusr);
  proto_init(uart_sink);
  uart_init();
  adc_init();
  adc_set_rate(FS_DEFAULT);
  sample_reset();
  sample_interval_restart();
  set_sleep_mode(SLEEP_MODE_IDLE);
  sei();

  report_boot();
  adc_start(0, 0);
  for (;;) {
    sample_pump();
    report_poll();
    poll_commands();
#if REPORT > 0
    if (!report_busy() && sample_stats.since_report >= (uint32_t)REPORT * adc_rate())
      report_start(); /* its header restarts the interval */
#endif
    /* Sleep until the next interrupt unless there is work to do now. */
    cli();
    if (!adc_pending() && !uart_rx_pending() && !(report_busy() && uart_tx_room() >= REPORT_STEP_MAX)) {
      sleep_enable();
      sei();
      sleep_cpu();
      sleep_disable();
    }
    sei();
  }
}
