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
#include <avr/wdt.h>

#include "adc.h"
#include "control.h"
#include "sample.h"
#include "stream.h"
#include "tx.h"
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

/* The watchdog resets the MCU if the loop stops for a second.  Its
 * interrupt comes first and only wakes the loop from sleep; the loop re-arms
 * it, a hung loop does not, and the next timeout resets. */
ISR(WDT_vect)
{
}

static void watchdog_kick(void)
{
  wdt_reset();
  WDTCSR |= (1 << WDIE);
}

/* Work the loop can do right now; without any, it sleeps until an
 * interrupt (a tick, a conversion, a byte in or out) brings some. */
static uint8_t has_work(void)
{
  uint8_t can_write = tx_can_write();
  if (adc_pending() && (!stream_holds_oldest() || can_write))
    return 1; /* a set to feed to the engine, or its row or frame to write */
  return control_has_work() || (tx_busy() && can_write);
}

/* main never returns: OS_main spares it saving registers on the stack. */
int main(void) __attribute__((OS_main));
int main(void)
{
  tx_init(main_mcusr);
  uart_init();
  adc_init();
  control_init();
  set_sleep_mode(SLEEP_MODE_IDLE);
  wdt_enable(WDTO_1S);
  watchdog_kick();
  sei();

  tx_boot();
  adc_start(0, 0);
  for (;;) {
    watchdog_kick();
    sample_feed(); /* the stream holds a set until its row or frame is out */
    tx_poll();
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
