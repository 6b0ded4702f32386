/*
 * main.c - imu-allan firmware: start-up, then the main loop.  Interrupts
 * fill rings; everything else happens in the loop below, which never waits
 * on the UART: a pass (loop.c) feeds finished sample sets to the engine,
 * lets the output scheduler write what the TX ring takes and runs
 * commands; the loop sleeps when there is nothing to do.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "adc.h"
#include "clock.h"
#include "control.h"
#include "loop.h"
#include "reset.h"
#include "switchboard.h"
#include "uart.h"

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
    if (loop_pass())
      continue; /* the engine's waiting work goes on at once */
    /* Sleep until the next interrupt unless there is work to do now. */
    cli();
    if (!loop_has_work()) {
      sleep_enable();
      sei();
      sleep_cpu();
      sleep_disable();
    }
    sei();
  }
}
