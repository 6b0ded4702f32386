/* loop.c - see loop.h. */
#include "loop.h"

#include "adc.h"
#include "board.h"
#include "console.h"
#include "control.h"
#include "sample.h"
#include "stream.h"
#include "switchboard.h"

uint8_t loop_pass(void)
{
  /* Sets to the engine (the stream holds a set until its row or frame is
   * out), received bytes to the console between two of them. */
  while (adc_pending() && !stream_holds_oldest()) {
    sample_take();
    stream_taken();
    console_receive();
  }
  /* The engine's waiting work, a piece a pass (a set that comes
   * meanwhile is taken first): the output below reads a settled engine. */
  if (sample_settle()) {
    console_receive(); /* between two pieces too: the RX ring lasts 0.69 ms */
    return 1;
  }
  switchboard_poll();
  if (BOARD_FLAGS & BOARD_FLAG_INTERVAL) { /* a report's header took the interval's temperature */
    BOARD_FLAGS &= (uint8_t)~BOARD_FLAG_INTERVAL;
    sample_interval_restart();
  }
  control_poll();
  return 0;
}

uint8_t loop_has_work(void)
{
  uint8_t can_write = switchboard_can_write();
  if (adc_pending() && (!stream_holds_oldest() || can_write))
    return 1; /* a set to feed to the engine, or its row or frame to write */
  return control_has_work() || (switchboard_busy() && can_write);
}
