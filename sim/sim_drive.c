/*
 * sim_drive.c - the batch run the harness drives (without --pty): after the
 * boot line, stop, rate, reset, start R; once the last row is converted,
 * report; done at the end of the final report.  Device lines come in from
 * sim_serial.c; the run loop and its timeouts are here too.
 */
#include "harness.h"

#include <stdlib.h>
#include <string.h>

/* What each state waits for, for the timeout message. */
static const char *const st_wait[] = {
  "the boot line ($B)", "the reply to 'stop'", "the reply to 'rate'",
  "the reply to 'reset'", "the reply to 'start'", "a sample",
  "the final report's header ($H with n = the rows)", "the report end ($E)",
  "", "", "",
};

uint64_t rows_consumed(void)
{
  return g.conv[ROW_COLUMNS - 1] < g.nrows ? g.conv[ROW_COLUMNS - 1] : g.nrows;
}

void release_uart_in(void)
{
  uint64_t n = rows_consumed();
  while (g.uin_next < g.nuin && g.uin[g.uin_next].index <= n)
    send_user(&g.uin[g.uin_next++]);
}

void set_state(int st)
{
  g.state = st;
  g.deadline = g.avr->cycle + g.timeout_cycles;
}

void finish_run(void)
{
  release_uart_in();
  send_cmd("report");
  set_state(ST_REPORT_H);
}

/* ---- device lines -------------------------------------------------------- */

/* Replies: the harness's own commands are told apart by their replies'
 * content, not by counting, since user input (--uart-in) may be noise whose
 * lines get one reply, none (blank, or lost whole) or an error. */
static int reply_is(const char *body, const char *prefix)
{
  return !strncmp(body, prefix, strlen(prefix));
}

static void on_reply(int ok, const char *body)
{
  static const char *const cmd[] = {
    [ST_STOP] = "stop", [ST_RATE] = "rate", [ST_RESET] = "reset",
    [ST_START] = "start", [ST_REPORT_H] = "report",
  };
  switch (g.state) {
  case ST_STOP: case ST_RATE: case ST_RESET: case ST_START:
    /* Set-up: no user input has been sent yet, so every reply is ours. */
    if (!ok) {
      fail(EXIT_FAIL, "the device answered '%s' with '%s'", cmd[g.state], body);
      return;
    }
    break;
  case ST_REPORT_H:
    if (!ok && reply_is(body, "error:4"))
      fail(EXIT_FAIL, "the device answered 'report' with '%s'", body);
    return;     /* 'ok' needs nothing: the report itself is awaited */
  default:
    return;     /* a reply to user input */
  }
  switch (g.state) {
  case ST_STOP:
    if (!reply_is(body, "ok stopped"))
      return;
    g.armed = 1;   /* the next conversion of each channel gets row 0 */
    if (g.fs) {
      send_cmd("rate %u", g.fs);
      set_state(ST_RATE);
      break;
    }
    send_cmd("reset");
    set_state(ST_RESET);
    break;
  case ST_RATE:
    if (!reply_is(body, "ok reset rate=") && !reply_is(body, "ok rate="))
      return;
    send_cmd("reset");
    set_state(ST_RESET);
    break;
  case ST_RESET:
    if (strcmp(body, "ok reset"))
      return;
    send_cmd("start %llu", (unsigned long long)g.nrows);
    set_state(ST_START);
    break;
  case ST_START:
    if (strcmp(body, "ok started"))
      return;
    set_state(ST_RUN);
    if (g.rows_done)
      finish_run();
    else
      release_uart_in();
    break;
  default:
    break;
  }
}

static long long key_value(const char *body, const char *key)
{
  const char *p = strstr(body, key);
  return p ? strtoll(p + strlen(key), NULL, 10) : -1;
}

void on_line(char *body, size_t len, int crc_ok)
{
  /* In terminal mode lines are only watched for a reboot: bad lines are
   * the user's business (and binary frames look like garbage). */
  if (!crc_ok && g.bad_crc++ == 0 && !g.pty)
    warn("t=%.6f s: device line with a bad CRC (used anyway): $%.*s*...",
         sim_time(), (int)len, body);
  if (!strcmp(body, "ok") || !strncmp(body, "ok ", 3)) {
    on_reply(1, body);
  } else if (!strncmp(body, "error", 5)) {
    on_reply(0, body);
  } else if (!strncmp(body, "B,", 2)) {
    if (g.boots++) {
      if (!g.board)     /* a board resets whenever its port is opened */
        warn("t=%.6f s: the device rebooted (boot line #%llu)", sim_time(),
             (unsigned long long)g.boots);
    } else if (g.state == ST_BOOT) {
      send_cmd("stop");
      set_state(ST_STOP);
    }
  } else if (!strncmp(body, "H,", 2)) {
    /* The final report: the one that covers every row (the device stopped
     * there by itself), whoever asked for it. */
    if (g.state == ST_REPORT_H && key_value(body, ",n=") == (long long)g.nrows) {
      g.report_seq = strtoul(body + 2, NULL, 10);
      g.dev_n = key_value(body, ",n=");
      g.dev_drops = key_value(body, ",drops=");
      set_state(ST_REPORT_E);
    }
  } else if (!strncmp(body, "E,", 2)) {
    if (g.state == ST_REPORT_E && strtoul(body + 2, NULL, 10) == g.report_seq) {
      /* let the line's LF out too: the run ends at the LF, or after a
       * few byte times of silence */
      g.state = ST_DRAIN;
      g.deadline = g.avr->cycle + 4 * byte_cycles();
    }
  }
}

/* ---- the run --------------------------------------------------------- */

int drive_run(void)
{
  avr_t *avr = g.avr;
  int st = cpu_Running;
  while (g.state != ST_DONE && !g.fail) {
    st = avr_run(avr);
    if (st == cpu_Crashed || st == cpu_Done || st == cpu_Stopped)
      break;
    watch_sp();
    if (avr->cycle >= g.deadline) {
      if (g.state == ST_DRAIN)
        break;
      if (g.state == ST_RUN)
        fail(EXIT_TIMEOUT, "timeout: no sample for %g simulated s after "
             "row %llu of %llu (t=%.3f s)", g.timeout_s,
             (unsigned long long)rows_consumed(),
             (unsigned long long)g.nrows, sim_time());
      else
        fail(EXIT_TIMEOUT, "timeout: waited %g simulated s for %s (t=%.3f s)",
             g.timeout_s, st_wait[g.state], sim_time());
    }
  }
  return st;
}

void drive_summary(int code)
{
  if (g.stray_conv)
    warn("%llu conversions took rows after 'stop' was acknowledged and "
         "before 'start' reached the device", (unsigned long long)g.stray_conv);
  if (g.extra_conv)
    warn("the device converted %llu channels (%llu scans) after the last row "
         "(it dropped samples?); they read the last row again",
         (unsigned long long)g.extra_conv, (unsigned long long)g.extra_scans);
  if (code == EXIT_OK && g.dev_drops > 0)
    warn("the final report says drops=%lld", g.dev_drops);
  if (code == EXIT_OK && g.dev_n >= 0 && (uint64_t)g.dev_n != g.nrows)
    warn("the final report says n=%lld, %llu rows were fed", g.dev_n,
         (unsigned long long)g.nrows);
  if (g.bad_crc > 1)
    warn("%llu device lines had a bad CRC", (unsigned long long)g.bad_crc);
  if (g.bytes_lost)
    warn("%llu host bytes were lost: the device's receiver was disabled",
         (unsigned long long)g.bytes_lost);
  if (code == EXIT_OK && g.uin_next < g.nuin)
    warn("%ld --uart-in lines were never sent (first: line %lu, index %llu > "
         "%llu rows)", g.nuin - g.uin_next, g.uin[g.uin_next].line,
         (unsigned long long)g.uin[g.uin_next].index,
         (unsigned long long)g.nrows);
}
