/*
 * main.c - imu-allan firmware: start-up, then the main loop.  Interrupts
 * fill rings; everything else happens in the loop below, which never waits
 * on the UART: it feeds finished sample sets to the engine, lets the output
 * scheduler write what the TX ring takes, runs commands, and sleeps when
 * there is nothing to do.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "adc.h"
#include "clock.h"
#include "console.h"
#include "control.h"
#include "reset.h"
#include "sample.h"
#include "stream.h"
#include "switchboard.h"
#include "uart.h"

/* Work the loop can do right now; without any, it sleeps until an
 * interrupt (a tick, a conversion, a byte in or out) brings some. */
static uint8_t has_work(void)
{
  uint8_t can_write = switchboard_can_write();
  if (adc_pending() && (!stream_holds_oldest() || can_write))
    return 1; /* a set to feed to the engine, or its row or frame to write */
  return control_has_work() || (switchboard_busy() && can_write);
}

/* main never returns: OS_main spares it saving registers on the stack. */
int main(void) __attribute__((OS_main));
int main(void)
{
  switchboard_init();
  uart_init();
  adc_init();
  clock_init();
  control_init();
  set_sleep_mode(SLEEP_MODE_IDLE);
  reset_watchdog_start();
  sei();

  switchboard_boot();
  adc_start(0, 0);
  for (;;) {
    reset_watchdog_kick();
    /* Sets to the engine (the stream holds a set until its row or frame is
     * out), received bytes to the console between two of them.  No set
     * waiting: sample_take's register saves are not paid for nothing. */
    while (adc_pending() && sample_take())
      console_receive();
    /* The engine's waiting work, a piece a pass (a set that comes
     * meanwhile is taken first): the output below reads a settled engine. */
    if (sample_settle()) {
      console_receive(); /* between two pieces too: the RX ring lasts 0.69 ms */
      continue;
    }
    switchboard_poll();
    control_poll();
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
