/*
 * sim_drive.c - the batch run the harness drives (without --pty): after the
 * boot line, stop, rate, reset, start R; once the last row is converted,
 * report; done at the end of the final report.  Device lines come in from
 * sim_serial.c; the run loop and its timeouts are here too.
 */
#include "sim_drive.h"

#include <stdlib.h>
#include <string.h>

#include "sim_adc.h"
#include "sim_fault.h"
#include "sim_msg.h"
#include "sim_serial.h"

/* What each state waits for, for the timeout message. */
static const char *const st_wait[] = {
  "the boot line ($B)",
  "the reply to 'stop'",
  "the reply to 'rate'",
  "the reply to 'reset'",
  "the reply to 'start'",
  "a sample",
  "the final report's header ($H with n = the rows)",
  "the report end ($E)",
  "",
  "",
  "",
};

/* --uart-in text whose row has come. */
static void release_uart_in(harness_t *h)
{
  uint64_t n = adc_rows_consumed(h);
  while (h->uin_next < h->nuin && h->uin[h->uin_next].index <= n)
    serial_send_user(h, &h->uin[h->uin_next++]);
}

static void set_state(harness_t *h, int st)
{
  h->state = st;
  /* the link is noisy (--link-loss, --link-flip) while the rows run: the
   * set-up and the final report pass clean, so the run itself keeps going */
  h->fault.link_on = st == ST_RUN;
  h->deadline = h->avr->cycle + h->timeout_cycles;
}

static void finish_run(harness_t *h)
{
  release_uart_in(h);
  /* a noisy link may have eaten the CR of a user line: close it first, so
   * that 'report' is not glued to its end */
  if (h->fault.loss > 0 || h->fault.flip > 0 || h->fault.overrun > 0 ||
      h->fault.no_flow)
    h->user_line_len = 1;
  serial_send_cmd(h, "report");
  set_state(h, ST_REPORT_H);
}

/* ---- device lines -------------------------------------------------------- */

/* After a reset in the middle of the run (a power cut, a brown-out): the
 * run starts again from the next row not yet converted, every channel from
 * the same row (a scan the reset cut short is skipped). */
static void restart(harness_t *h)
{
  h->restarts++;
  h->armed = 0; /* conversions read 512 and take no row until 'ok stopped' */
  serial_send_cmd(h, "stop");
  set_state(h, ST_STOP);
}

static void rearm(harness_t *h)
{
  uint64_t k = 0;
  for (int c = 0; c < ROW_COLUMNS; c++)
    if (h->conv[c] > k)
      k = h->conv[c];
  for (int c = 0; c < ROW_COLUMNS; c++)
    h->conv[c] = k;
  if (k >= h->nrows)
    fail(h, EXIT_FAIL,
         "the device was reset after the last row: no row left to "
         "run again");
  h->first_row = k;
}

/* Replies: the harness's own commands are told apart by their replies'
 * content, not by counting, since user input (--uart-in) may be noise whose
 * lines get one reply, none (blank, or lost whole) or an error. */
static int reply_is(const char *body, const char *prefix)
{
  return !strncmp(body, prefix, strlen(prefix));
}

static void on_reply(harness_t *h, int ok, const char *body)
{
  static const char *const cmd[] = {
    [ST_STOP] = "stop",   [ST_RATE] = "rate",       [ST_RESET] = "reset",
    [ST_START] = "start", [ST_REPORT_H] = "report",
  };
  switch (h->state) {
  case ST_STOP:
  case ST_RATE:
  case ST_RESET:
  case ST_START:
    /* Set-up: no user input has been sent yet, so every reply is ours
     * (after a restart, user input may still be on its way). */
    if (!ok && !h->restarts) {
      fail(h, EXIT_FAIL, "the device answered '%s' with '%s'", cmd[h->state],
           body);
      return;
    }
    break;
  case ST_REPORT_H:
    if (!ok && reply_is(body, "error:4"))
      fail(h, EXIT_FAIL, "the device answered 'report' with '%s'", body);
    /* an injected fault may have cost 'report' a byte (a data overrun's
     * DOR lands on the next frame that arrives): ask again */
    if (!ok && reply_is(body, "error:5") && fault_any(&h->fault) &&
        h->report_retries++ < 3)
      serial_send_cmd(h, "report");
    return;        /* 'ok' needs nothing: the report itself is awaited */
  default: return; /* a reply to user input */
  }
  switch (h->state) {
  case ST_STOP:
    if (!reply_is(body, "ok stopped"))
      return;
    if (h->restarts)
      rearm(h);
    h->armed = 1; /* the next conversion of each channel gets row 0 */
    if (h->fs) {
      serial_send_cmd(h, "rate %u", h->fs);
      set_state(h, ST_RATE);
      break;
    }
    serial_send_cmd(h, "reset");
    set_state(h, ST_RESET);
    break;
  case ST_RATE:
    if (!reply_is(body, "ok reset rate=") && !reply_is(body, "ok rate="))
      return;
    serial_send_cmd(h, "reset");
    set_state(h, ST_RESET);
    break;
  case ST_RESET:
    if (strcmp(body, "ok reset"))
      return;
    serial_send_cmd(h, "start %llu",
                    (unsigned long long)(h->nrows - h->first_row));
    set_state(h, ST_START);
    break;
  case ST_START:
    if (strcmp(body, "ok started"))
      return;
    set_state(h, ST_RUN);
    if (h->rows_done)
      finish_run(h);
    else
      release_uart_in(h);
    break;
  default: break;
  }
}

static long long key_value(const char *body, const char *key)
{
  const char *p = strstr(body, key);
  return p ? strtoll(p + strlen(key), NULL, 10) : -1;
}

static void on_line(harness_t *h, char *body, size_t len, int crc_ok)
{
  if (h->state == ST_DRAIN || h->state == ST_DONE)
    return; /* the run is over: only the last LF is awaited */
  /* In terminal mode lines are only watched for a reboot: bad lines are
   * the user's business (and binary frames look like garbage). */
  if (!crc_ok && h->bad_crc++ == 0 && !h->pty)
    warn("t=%.6f s: device line with a bad CRC (used anyway): $%.*s*...",
         sim_time(h), (int)len, body);
  if (!strcmp(body, "ok") || !strncmp(body, "ok ", 3)) {
    on_reply(h, 1, body);
  } else if (!strncmp(body, "error", 5)) {
    on_reply(h, 0, body);
  } else if (!strncmp(body, "B,", 2)) {
    if (h->boots++) {
      if (!h->board && !h->fault.resets) /* one the harness did not cause */
        warn("t=%.6f s: the device rebooted (boot line #%llu)", sim_time(h),
             (unsigned long long)h->boots);
      if (h->state != ST_BOOT)
        restart(h);
    } else if (h->state == ST_BOOT) {
      serial_send_cmd(h, "stop");
      set_state(h, ST_STOP);
    }
  } else if (!strncmp(body, "H,", 2)) {
    /* The final report: the one that covers every row (the device stopped
     * there by itself), whoever asked for it. */
    if (h->state == ST_REPORT_H &&
        key_value(body, ",n=") == (long long)(h->nrows - h->first_row)) {
      h->report_seq = strtoul(body + 2, NULL, 10);
      h->dev_n = key_value(body, ",n=");
      h->dev_drops = key_value(body, ",drops=");
      set_state(h, ST_REPORT_E);
    }
  } else if (!strncmp(body, "E,", 2)) {
    if (h->state == ST_REPORT_E &&
        strtoul(body + 2, NULL, 10) == h->report_seq) {
      /* let the line's LF out too: the run ends at the LF, or after a
       * few byte times of silence */
      h->state = ST_DRAIN;
      h->deadline = h->avr->cycle + 4 * serial_byte_cycles(h);
    }
  }
}

/* The end of the run: the LF that closes the final report's E line. */
static void on_byte(harness_t *h, uint8_t c)
{
  if (h->state == ST_DRAIN && c == '\n')
    h->state = ST_DONE;
}

/* Each row converted (mux 6): the next --uart-in text, the end of the rows. */
static void on_scan(harness_t *h)
{
  uint64_t n = adc_rows_consumed(h);
  if (h->state == ST_RUN) {
    h->deadline = h->avr->cycle + h->timeout_cycles;
    release_uart_in(h);
  }
  if (n == h->nrows && !h->rows_done) {
    h->rows_done = 1;
    if (h->state == ST_RUN)
      finish_run(h);
  }
}

void drive_connect(harness_t *h)
{
  h->on_line = on_line;
  h->on_byte = on_byte;
  h->on_scan = on_scan;
  set_state(h, ST_BOOT);
}

/* ---- the run --------------------------------------------------------- */

int drive_run(harness_t *h)
{
  avr_t *avr = h->avr;
  int st = cpu_Running;
  while (h->state != ST_DONE && !h->fail) {
    st = avr_run(avr);
    if (st == cpu_Crashed || st == cpu_Done || st == cpu_Stopped)
      break;
    watch_sp(h);
    if (avr->cycle >= h->fault.next_at && fault_poll(h)) {
      serial_after_reset(h); /* simavr dropped the cycle timers */
      h->deadline = avr->cycle + h->timeout_cycles;
    }
    if (avr->cycle >= h->deadline) {
      if (h->state == ST_DRAIN)
        break;
      if (h->state == ST_RUN)
        fail(h, EXIT_TIMEOUT,
             "timeout: no sample for %g simulated s after "
             "row %llu of %llu (t=%.3f s)",
             h->timeout_s, (unsigned long long)adc_rows_consumed(h),
             (unsigned long long)h->nrows, sim_time(h));
      else
        fail(h, EXIT_TIMEOUT,
             "timeout: waited %g simulated s for %s (t=%.3f s)", h->timeout_s,
             st_wait[h->state], sim_time(h));
    }
  }
  return st;
}

void drive_summary(harness_t *h, int code)
{
  if (h->stray_conv)
    warn("%llu conversions took rows after 'stop' was acknowledged and "
         "before 'start' reached the device",
         (unsigned long long)h->stray_conv);
  if (h->extra_conv)
    warn("the device converted %llu channels (%llu scans) after the last row "
         "(it dropped samples?); they read the last row again",
         (unsigned long long)h->extra_conv, (unsigned long long)h->extra_scans);
  if (code == EXIT_OK && h->dev_drops > 0)
    warn("the final report says drops=%lld", h->dev_drops);
  if (code == EXIT_OK && h->dev_n >= 0 &&
      (uint64_t)h->dev_n != h->nrows - h->first_row)
    warn("the final report says n=%lld, %llu rows were fed", h->dev_n,
         (unsigned long long)(h->nrows - h->first_row));
  if (h->bad_crc > 1)
    warn("%llu device lines had a bad CRC", (unsigned long long)h->bad_crc);
  if (h->bytes_lost)
    warn("%llu host bytes were lost: the device's receiver was disabled",
         (unsigned long long)h->bytes_lost);
  if (code == EXIT_OK && h->uin_next < h->nuin)
    warn("%ld --uart-in lines were never sent (first: line %lu, index %llu > "
         "%llu rows)",
         h->nuin - h->uin_next, h->uin[h->uin_next].line,
         (unsigned long long)h->uin[h->uin_next].index,
         (unsigned long long)h->nrows);
}
