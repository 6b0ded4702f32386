/*
 * sim_msg.c - imu-sim's messages: warnings, fatal errors, failures found
 * inside simavr callbacks (the run loop stops on them), simavr's own log.
 */
#include "sim_msg.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* One line on stderr: the prefix, then the message. */
static void say(const char *prefix, const char *fmt, va_list ap)
{
  fputs(prefix, stderr);
  vfprintf(stderr, fmt, ap);
  fputc('\n', stderr);
}

/* The state simavr's logger reads (its callback carries no pointer). */
static harness_t *log_h;

void msg_init(harness_t *h)
{
  log_h = h;
}

void warn(const char *fmt, ...)
{
  va_list ap;
  va_start(ap, fmt);
  say(PROG ": warning: ", fmt, ap);
  va_end(ap);
}

void die(int code, const char *fmt, ...)
{
  va_list ap;
  va_start(ap, fmt);
  say(PROG ": ", fmt, ap);
  va_end(ap);
  exit(code);
}

void fail(harness_t *h, int code, const char *fmt, ...)
{
  va_list ap;
  if (h->fail)
    return;
  va_start(ap, fmt);
  vsnprintf(h->fail_msg, sizeof h->fail_msg, fmt, ap);
  va_end(ap);
  h->fail = code;
}

double sim_time(const harness_t *h)
{
  return h->avr ? (double)h->avr->cycle / h->avr->frequency : 0.0;
}

void logger(avr_t *avr, const int level, const char *fmt, va_list ap)
{
  harness_t *h = log_h;
  char msg[240], *w = msg;
  (void)avr;
  if (!h)
    return;
  int show = h->verbose >= 2 ? LOG_TRACE : LOG_WARNING;
  if (h->log_quiet || (level > show && level != LOG_ERROR))
    return;
  vsnprintf(msg, sizeof msg, fmt, ap);
  /* drop simavr's colour escapes and line ends */
  for (const char *r = msg; *r; r++) {
    if (*r == '\033') {
      while (r[1] && !(r[1] >= '@' && r[1] <= '~' && r[1] != '['))
        r++;
      if (r[1])
        r++;
    } else if (*r != '\n' && *r != '\r') {
      *w++ = *r;
    }
  }
  *w = 0;
  /* Errors usually announce a crash: they go into its one-line message
   * (or into a warning at the end), shown at once only with -v. */
  if (level == LOG_ERROR) {
    if (!strncmp(msg, "avr_sadly_crashed", 17))
      return;
    snprintf(h->last_error, sizeof h->last_error, "%.199s", msg);
    h->errors++;
    if (!h->verbose)
      return;
  }
  /* simavr 1.6 warns about any OCRnx write while the timer's clock is
   * stopped; the value is applied when the clock starts: noise. */
  if (!h->verbose && strstr(msg, "avr_timer_write_ocr") &&
      strstr(msg, "mode 0 UNSUPPORTED"))
    return;
  /* simavr's self-programming module warns when SPMCSR's SELFPRGEN times
   * out after an SPM it has already carried out (optiboot's page writes
   * land and verify): noise too. */
  if (!h->verbose && strstr(msg, "SPM not received"))
    return;
  if (level > show)
    return;
  if (!h->verbose && h->log_shown >= LOG_CAP) {
    if (h->log_shown++ == LOG_CAP)
      fputs(PROG ": simavr: further messages suppressed (use -v)\n", stderr);
    return;
  }
  h->log_shown++;
  fprintf(stderr, PROG ": simavr: %s\n", msg);
}
