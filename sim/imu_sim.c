/*
 * imu_sim.c - imu-sim: run the imu-allan firmware ELF in simavr, feed its
 * ADC the rows of a thesis data file (row i to the i-th conversion of each
 * channel), drive it through the serial protocol of docs/protocol.md and
 * capture everything it sends.  `imu-sim --help` tells the whole story.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <gelf.h>
#include <getopt.h>
#include <libelf.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"
#include "sim_regbit.h"
#include "avr_adc.h"
#include "avr_timer.h"
#include "avr_eeprom.h"
#include "avr_ioport.h"
#include "avr_uart.h"

#include "sim_isr.h"
#include "sim_rows.h"
#include "sim_term.h"

/* the accessors of avr_uart.h's receive FIFO (avr_uart_t.input) */
DEFINE_FIFO(uint16_t, uart_fifo);

#define PROG "imu-sim"
#define NEUTRAL_CODE 512
#define ROW_WIN 64          /* rows kept for channels that lag behind */
#define LINE_MAX_LEN 256    /* protocol bodies are at most 200 chars */
#define PAINT 0xA5          /* SRAM fill for the stack high-water mark */
#define LOG_CAP 20          /* simavr messages shown without -v */

enum { EXIT_OK = 0, EXIT_FAIL = 1, EXIT_INPUT = 2, EXIT_TIMEOUT = 3 };

/* Harness states: each but RUN and DONE waits for one device line.
 * TERM: terminal mode (--pty), where the user drives the device. */
enum { ST_BOOT, ST_STOP, ST_RATE, ST_RESET, ST_START, ST_RUN,
       ST_REPORT_H, ST_REPORT_E, ST_DRAIN, ST_DONE, ST_TERM };
static const char *const st_wait[] = {
  "the boot line ($B)", "the reply to 'stop'", "the reply to 'rate'",
  "the reply to 'reset'", "the reply to 'start'", "a sample",
  "the final report's header ($H with n = the rows)", "the report end ($E)",
  "", "", "",
};

typedef struct {
  int level;
  avr_cycle_count_t rise;
  int seen_rise;
  uint64_t count;
  uint64_t sum, max;
} pulse_t;

static struct {
  /* options */
  const char *adc_path, *uart_in_path, *out_path, *stats_json, *elf_path;
  const char *eeprom_path;
  const char *mcu;
  uint32_t freq;
  unsigned fs;
  double timeout_s;
  int stats_text, verbose;
  /* terminal mode */
  int pty, synthetic, fast, realtime, no_wait, timeout_set;
  const char *link_path;
  uint64_t seed;

  avr_t *avr;
  avr_adc_t *adc;
  avr_uart_t *uart;
  avr_irq_t *adc_irq, *uart_irq;

  /* protocol state */
  int state;
  avr_cycle_count_t deadline, timeout_cycles;
  int fail;                   /* exit code of a failure found in a callback */
  char fail_msg[320];

  /* ADC rows */
  rows_t rows;
  synth_t synth;
  uint64_t nrows, loaded, file_rows, file_loops;
  uint16_t win[ROW_WIN][ROW_COLUMNS];
  int armed, rows_done, order_warned, ref_warned, mux_warned;
  uint64_t conv[ROW_COLUMNS];
  uint64_t extra_conv, extra_scans, stray_conv, other_conv, neutral_conv;
  uint16_t last_code;

  /* host -> device bytes */
  uint8_t *txq;
  size_t txq_head, txq_len, txq_cap;
  int tx_busy, xoff;
  avr_cycle_count_t tx_free_at;
  uint64_t bytes_in, bytes_lost, xoffs;
  uart_in_t *uin;
  long nuin, uin_next;
  size_t user_line_len;

  /* device -> host bytes */
  FILE *out;
  uint64_t bytes_out;
  char line[LINE_MAX_LEN];
  int line_len, in_line;
  uint64_t bad_crc, bad_frame, boots;
  unsigned long report_seq;
  long long dev_n, dev_drops;

  /* measurements */
  pulse_t pb0, pb1, pb2;
  avr_cycle_count_t slept;
  uint16_t bss_end;
  uint16_t sp_min;            /* lowest stack pointer seen */
  uint32_t sp_min_pc;         /* program counter (bytes) when it was seen */
  double wall_s;

  /* simavr log */
  char last_error[200];
  int log_shown;
  int log_quiet;
  uint64_t errors;
} g = { .timeout_s = 5.0, .dev_n = -1, .dev_drops = -1, .sp_min = 0xFFFF,
        .seed = 1 };

/* ---- messages -------------------------------------------------------- */

static void warn(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static void warn(const char *fmt, ...)
{
  va_list ap;
  va_start(ap, fmt);
  fputs(PROG ": warning: ", stderr);
  vfprintf(stderr, fmt, ap);
  fputc('\n', stderr);
  va_end(ap);
}

static void die(int code, const char *fmt, ...)
  __attribute__((format(printf, 2, 3), noreturn));
static void die(int code, const char *fmt, ...)
{
  va_list ap;
  va_start(ap, fmt);
  fputs(PROG ": ", stderr);
  vfprintf(stderr, fmt, ap);
  fputc('\n', stderr);
  va_end(ap);
  exit(code);
}

/* A failure found inside a simavr callback: the run loop stops on it. */
static void fail(int code, const char *fmt, ...)
  __attribute__((format(printf, 2, 3)));
static void fail(int code, const char *fmt, ...)
{
  va_list ap;
  if (g.fail)
    return;
  va_start(ap, fmt);
  vsnprintf(g.fail_msg, sizeof g.fail_msg, fmt, ap);
  va_end(ap);
  g.fail = code;
}

static double sim_time(void)
{
  return g.avr ? (double)g.avr->cycle / g.avr->frequency : 0.0;
}

static void logger(avr_t *avr, const int level, const char *fmt, va_list ap)
{
  int show = g.verbose >= 2 ? LOG_TRACE : LOG_WARNING;
  char msg[240], *w = msg;
  (void)avr;
  if (g.log_quiet || (level > show && level != LOG_ERROR))
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
    snprintf(g.last_error, sizeof g.last_error, "%.199s", msg);
    g.errors++;
    if (!g.verbose)
      return;
  }
  /* simavr 1.6 warns about any OCRnx write while the timer's clock is
   * stopped; the value is applied when the clock starts: noise. */
  if (!g.verbose && strstr(msg, "avr_timer_write_ocr") &&
      strstr(msg, "mode 0 UNSUPPORTED"))
    return;
  if (level > show)
    return;
  if (!g.verbose && g.log_shown >= LOG_CAP) {
    if (g.log_shown++ == LOG_CAP)
      fputs(PROG ": simavr: further messages suppressed (use -v)\n", stderr);
    return;
  }
  g.log_shown++;
  fprintf(stderr, PROG ": simavr: %s\n", msg);
}

/* ---- host -> device: paced UART input -------------------------------- */

/* One byte on the wire: start + 8 data + stop bit(s), at the baud rate
 * the firmware programmed. */
static avr_cycle_count_t byte_cycles(void)
{
  avr_t *avr = g.avr;
  avr_uart_t *u = g.uart;
  uint32_t ubrr = avr_regbit_get(avr, u->ubrrl) |
                  (uint32_t)avr_regbit_get(avr, u->ubrrh) << 8;
  uint32_t bits = 10 + avr_regbit_get(avr, u->usbs);
  return (avr_cycle_count_t)bits * (ubrr + 1) * (avr_regbit_get(avr, u->u2x) ? 8 : 16);
}

/* Sends the next queued byte, then comes back one byte time later.  While
 * simavr's receive FIFO is full (XOFF) it waits, polling the FIFO once a
 * byte time, so a missed XON cannot stall it. */
static avr_cycle_count_t tx_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
  (void)param;
  if (!g.txq_len) {
    g.tx_busy = 0;      /* restarted by tx_push() */
    return 0;
  }
  if (g.xoff || uart_fifo_isfull(&g.uart->input)) {
    if (uart_fifo_isfull(&g.uart->input))
      return when + byte_cycles();
    g.xoff = 0;
  }
  uint8_t c = g.txq[g.txq_head++];
  g.txq_len--;
  if (!g.txq_len)
    g.txq_head = 0;
  if (!avr_regbit_get(avr, g.uart->rxen))
    g.bytes_lost++;     /* simavr drops it, as the hardware would */
  avr_raise_irq(g.uart_irq + UART_IRQ_INPUT, c);
  g.bytes_in++;
  g.tx_free_at = when + byte_cycles();
  if (!g.txq_len) {
    g.tx_busy = 0;
    return 0;
  }
  return g.tx_free_at;
}

static void tx_kick(void)
{
  if (g.tx_busy || !g.txq_len)
    return;
  avr_cycle_count_t now = g.avr->cycle;
  g.tx_busy = 1;
  avr_cycle_timer_register(g.avr, g.tx_free_at > now ? g.tx_free_at - now : 1,
                           tx_timer, NULL);
}

static void tx_push(const uint8_t *b, size_t n)
{
  if (g.txq_head + g.txq_len + n > g.txq_cap) {
    memmove(g.txq, g.txq + g.txq_head, g.txq_len);
    g.txq_head = 0;
    if (g.txq_len + n > g.txq_cap) {
      g.txq_cap = 2 * (g.txq_len + n) + 256;
      g.txq = realloc(g.txq, g.txq_cap);
      if (!g.txq)
        die(EXIT_FAIL, "out of memory");
    }
  }
  memcpy(g.txq + g.txq_head + g.txq_len, b, n);
  g.txq_len += n;
  tx_kick();
}

static void xon_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  (void)irq; (void)param;
  if (value)
    g.xoff = 0;
}

static void xoff_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  (void)irq; (void)param;
  if (value && !g.xoff)
    g.xoffs++;
  g.xoff = value != 0;
}

/* A harness command: ends an unterminated user line first, so that the
 * two never merge into one command. */
static void send_cmd(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static void send_cmd(const char *fmt, ...)
{
  char buf[64];
  va_list ap;
  if (g.user_line_len) {
    tx_push((const uint8_t *)"\r", 1);
    g.user_line_len = 0;
  }
  va_start(ap, fmt);
  int n = vsnprintf(buf, sizeof buf - 1, fmt, ap);
  va_end(ap);
  buf[n++] = '\r';
  tx_push((const uint8_t *)buf, (size_t)n);
}

/* User text: remember whether it left a line open (send_cmd closes it). */
static void send_user(const uart_in_t *u)
{
  for (size_t i = 0; i < u->len; i++) {
    if (u->bytes[i] == '\r' || u->bytes[i] == '\n')
      g.user_line_len = 0;
    else
      g.user_line_len++;
  }
  tx_push(u->bytes, u->len);
}

static uint64_t rows_consumed(void)
{
  return g.conv[ROW_COLUMNS - 1] < g.nrows ? g.conv[ROW_COLUMNS - 1] : g.nrows;
}

static void release_uart_in(void)
{
  uint64_t n = rows_consumed();
  while (g.uin_next < g.nuin && g.uin[g.uin_next].index <= n)
    send_user(&g.uin[g.uin_next++]);
}

static void set_state(int st)
{
  g.state = st;
  g.deadline = g.avr->cycle + g.timeout_cycles;
}

static void finish_run(void)
{
  release_uart_in();
  send_cmd("report");
  set_state(ST_REPORT_H);
}

/* ---- ADC: row i to the i-th conversion of each channel --------------- */

static void fatal_rows(const char *err)
{
  fail(EXIT_INPUT, "%s", err);
}

/* The next input row: from the file, or (terminal mode) from the file
 * again from its start once it ends, or from the synthetic IMU. */
static int next_row(uint16_t code[ROW_COLUMNS], char *err, size_t errlen)
{
  if (g.synthetic) {
    synth_next(&g.synth, code);
    return 1;
  }
  int got = rows_next(&g.rows, code, err, errlen);
  if (got == 0 && g.pty) {
    if (rows_rewind(&g.rows, err, errlen))
      return -1;
    g.file_loops++;
    got = rows_next(&g.rows, code, err, errlen);
  }
  return got;
}

static uint16_t serve(int ch)
{
  uint64_t k = g.conv[ch]++;

  if (k >= g.nrows) {
    g.extra_conv++;
    if (ch == ROW_COLUMNS - 1)
      g.extra_scans++;
    return g.win[(g.nrows - 1) % ROW_WIN][ch];
  }
  if (g.state < ST_START || (g.state == ST_START && g.txq_len))
    g.stray_conv++;
  if (!g.order_warned &&
      ((ch > 0 && g.conv[ch - 1] <= k) ||
       (ch == 0 && k > 0 && g.conv[ROW_COLUMNS - 1] < k))) {
    g.order_warned = 1;
    warn("t=%.6f s: conversion %llu of mux %d is out of scan order "
         "(mux 0..6 expected in turn); rows may be misaligned",
         sim_time(), (unsigned long long)k, ch);
  }
  while (g.loaded <= k) {
    uint64_t lag = k;
    int lagger = ch;
    for (int c = 0; c < ROW_COLUMNS; c++)
      if (c != ch && g.conv[c] < lag) {
        lag = g.conv[c];
        lagger = c;
      }
    if (g.loaded >= lag + ROW_WIN) {
      fail(EXIT_FAIL, "t=%.6f s: mux %d ran %d conversions ahead of mux %d; "
           "imu-sim serves row i to the i-th conversion of each channel",
           sim_time(), ch, ROW_WIN, lagger);
      return NEUTRAL_CODE;
    }
    char err[256];
    int got = next_row(g.win[g.loaded % ROW_WIN], err, sizeof err);
    if (got <= 0) {
      fatal_rows(got < 0 ? err : "ADC file changed while running");
      return NEUTRAL_CODE;
    }
    g.loaded++;
  }
  return g.win[k % ROW_WIN][ch];
}

static void row_consumed(void)
{
  uint64_t n = rows_consumed();
  if (g.state == ST_RUN) {
    g.deadline = g.avr->cycle + g.timeout_cycles;
    release_uart_in();
  }
  if (n == g.nrows && !g.rows_done) {
    g.rows_done = 1;
    if (g.state == ST_RUN)
      finish_run();
  }
}

static const char *ref_name(uint16_t ref)
{
  switch (ref) {
  case ADC_VREF_AREF: return "AREF";
  case ADC_VREF_VCC: return "VCC";
  case ADC_VREF_AVCC: return "AVCC";
  case ADC_VREF_V110: return "internal 1.1 V";
  case ADC_VREF_V256: return "internal 2.56 V";
  default: return "?";
  }
}

/* simavr converts at ADCL read time: code = mV * 1023 / Vref, with mux and
 * Vref of that moment.  AVCC and AREF are set to 1023 "mV", so mV == code;
 * an internal reference gets mV rounded up so that the code is exact too. */
static uint32_t code_to_mv(uint16_t code)
{
  avr_t *avr = g.avr;
  uint8_t refi = avr_regbit_get_array(avr, g.adc->ref, ARRAY_SIZE(g.adc->ref));
  uint16_t ref = g.adc->ref_values[refi];
  uint32_t vref;
  switch (ref) {
  case ADC_VREF_AVCC: vref = avr->avcc; break;
  case ADC_VREF_AREF: vref = avr->aref; break;
  case ADC_VREF_VCC: vref = avr->vcc ? avr->vcc : 3300; break;
  default: vref = ref; break;
  }
  if (ref != ADC_VREF_AVCC && !g.ref_warned) {
    g.ref_warned = 1;
    warn("t=%.6f s: the firmware converts against %s (board.h: AVCC); "
         "codes are delivered exactly anyway", sim_time(), ref_name(ref));
  }
  return ((uint32_t)code * vref + 1022) / 1023;
}

static void adc_trigger(avr_irq_t *irq, uint32_t value, void *param)
{
  union { avr_adc_mux_t mux; uint32_t v; } e = { .v = value };
  avr_t *avr = g.avr;
  avr_adc_t *p = g.adc;
  uint16_t code;
  int ch = -1;
  (void)irq; (void)param;
  sim_isr_note_adsc();

  /* The hardware keeps the last result until the next one completes;
   * simavr computes it when ADCL is read.  Latch a result the firmware
   * has not read yet before the new values go in. */
  if (p->read_status == 0) {
    uint16_t reg = (uint16_t)(g.last_code << (avr_regbit_get(avr, p->adlar) ? 6 : 0));
    avr->data[p->r_adcl] = (uint8_t)reg;
    avr->data[p->r_adch] = (uint8_t)(reg >> 8);
    p->read_status = 1;
  }

  if (e.mux.kind == ADC_MUX_SINGLE && e.mux.src < ROW_COLUMNS)
    ch = e.mux.src;
  if (ch < 0) {
    g.other_conv++;
    if (!g.mux_warned) {
      g.mux_warned = 1;
      warn("t=%.6f s: the firmware converts mux kind %u source %u, not an "
           "IMU column (mux 0..6); it reads 0", sim_time(),
           (unsigned)e.mux.kind, (unsigned)e.mux.src);
    }
    code = 0;
  } else if (!g.armed) {
    g.neutral_conv++;
    code = NEUTRAL_CODE;
  } else {
    code = serve(ch);
  }

  /* All eight inputs carry the value: the firmware may switch ADMUX to the
   * next channel before it reads this result, and simavr would then read
   * that channel's input. */
  uint32_t mv = code_to_mv(code);
  if (ch >= 0)
    avr_raise_irq(g.adc_irq + ADC_IRQ_ADC0 + ch, mv);
  for (int i = 0; i < 8; i++)
    if (i != ch)
      avr_raise_irq(g.adc_irq + ADC_IRQ_ADC0 + i, mv);
  g.last_code = code;

  if (ch == ROW_COLUMNS - 1 && g.armed)
    row_consumed();
}

/* ---- terminal mode (--pty): the device's serial port on a pty --------- */

/* Set by SIGINT, SIGTERM, SIGHUP: the terminal loop ends. */
static volatile sig_atomic_t stop_signal;

static struct {
  pty_t pty;
  FILE *info;                 /* the real stdout: the device path */
  int connected;              /* a terminal has the slave open */
  uint8_t obuf[4096];         /* device bytes not yet written to the master */
  size_t olen;
  uint64_t unheard;           /* bytes sent while no terminal was open */
  uint64_t dropped;           /* bytes the terminal did not read in time */
  uint64_t from_term;         /* bytes read from the terminal */
  uint64_t resyncs;           /* times the host fell behind real time */
  avr_cycle_count_t slice, next_io, c0;
  struct timespec t0;
} t = { .pty = { .master = -1 } };

static double since(const struct timespec *a)
{
  struct timespec now;
  clock_gettime(CLOCK_MONOTONIC, &now);
  return (double)(now.tv_sec - a->tv_sec) + (now.tv_nsec - a->tv_nsec) * 1e-9;
}

static void sleep_s(double s)
{
  if (s <= 0)
    return;
  struct timespec ts = { (time_t)s, (long)((s - (double)(time_t)s) * 1e9) };
  nanosleep(&ts, NULL);       /* a signal ends it early: fine */
}

/* Is a terminal there?  Reads what it typed while the harness has room
 * for it: the rest waits in the pty, so a long paste blocks its writer
 * instead of piling up here.  Bytes go to the device paced at the baud
 * rate, honouring the receive FIFO's flow control (tx_push). */
static void term_poll(void)
{
  int readable;
  int now = pty_state(&t.pty, &readable);
  if (now != t.connected) {
    t.connected = now;
    if (g.verbose)
      fprintf(stderr, PROG ": t=%.3f s: terminal %s\n", sim_time(),
              now ? "opened" : "closed");
  }
  while (t.connected && readable && g.txq_len < 64) {
    uint8_t buf[64];
    ssize_t n = read(t.pty.master, buf, sizeof buf - g.txq_len);
    if (n > 0) {
      t.from_term += (uint64_t)n;
      tx_push(buf, (size_t)n);
      continue;
    }
    if (n < 0 && errno == EINTR)
      continue;
    if (n < 0 && errno != EAGAIN)
      t.connected = 0;        /* EIO: the terminal went away */
    break;
  }
}

/* Device bytes to the terminal.  With no terminal they are lost, as on a
 * serial line with nothing attached.  A terminal that does not read:
 * real time drops what does not fit (the device cannot wait); --fast
 * waits for it, since simulated time can. */
static void term_flush(void)
{
  size_t off = 0;
  while (off < t.olen) {
    if (!t.connected) {
      t.unheard += t.olen - off;
      break;
    }
    ssize_t n = write(t.pty.master, t.obuf + off, t.olen - off);
    if (n > 0) {
      off += (size_t)n;
      continue;
    }
    if (n < 0 && errno == EINTR)
      continue;
    if (n < 0 && errno != EAGAIN) {
      t.connected = 0;
      continue;
    }
    if (!g.fast || stop_signal) {
      if (!t.dropped)
        warn("t=%.3f s: the terminal does not read: device output is lost",
             sim_time());
      t.dropped += t.olen - off;
      break;
    }
    struct pollfd q = { .fd = t.pty.master, .events = POLLOUT };
    if (poll(&q, 1, 100) > 0 && (q.revents & (POLLHUP | POLLERR)))
      t.connected = 0;
  }
  t.olen = 0;
}

static void term_out(uint8_t c)
{
  t.obuf[t.olen++] = c;
  if (t.olen == sizeof t.obuf)
    term_flush();
}

/* Real time: hold the simulation until the wall clock catches up with
 * it, serving the terminal meanwhile.  A host too slow for real time
 * restarts the comparison rather than rushing to catch up. */
static void term_pace(void)
{
  for (;;) {
    double ahead = (double)(g.avr->cycle - t.c0) / g.avr->frequency - since(&t.t0);
    if (ahead < -0.25) {
      if (!t.resyncs++)
        warn("t=%.3f s: the host cannot keep up with real time; "
             "simulated time runs slower", sim_time());
      clock_gettime(CLOCK_MONOTONIC, &t.t0);
      t.c0 = g.avr->cycle;
      return;
    }
    if (ahead <= 0 || stop_signal)
      return;
    if (t.connected && g.txq_len < 64) {
      /* wake up early for typed bytes */
      struct pollfd q = { .fd = t.pty.master, .events = POLLIN };
      struct timespec ts = { 0, (long)(ahead * 1e9) };
      if (ppoll(&q, 1, &ts, NULL) > 0)
        term_poll();
      if (!t.connected)
        sleep_s(ahead);
    } else {
      sleep_s(ahead);
    }
  }
}

/* ---- device -> host: capture and protocol lines ----------------------- */

static uint16_t crc16(const char *s, size_t n)
{
  uint16_t c = 0xFFFF;
  while (n--) {
    c ^= (uint16_t)((uint8_t)*s++ << 8);
    for (int i = 0; i < 8; i++)
      c = (c & 0x8000) ? (uint16_t)((c << 1) ^ 0x1021) : (uint16_t)(c << 1);
  }
  return c;
}

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

static void on_line(char *body, size_t len, int crc_ok)
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

static void end_line(void)
{
  char *star = NULL;
  g.in_line = 0;
  g.line[g.line_len] = 0;
  for (int i = g.line_len - 1; i >= 0; i--)
    if (g.line[i] == '*') {
      star = g.line + i;
      break;
    }
  if (!star || g.line + g.line_len - star != 5) {
    if (g.bad_frame++ == 0 && !g.pty)
      warn("t=%.6f s: device line without a *CRC: $%s", sim_time(), g.line);
    return;
  }
  char *end;
  unsigned long crc = strtoul(star + 1, &end, 16);
  size_t len = (size_t)(star - g.line);
  int crc_ok = *end == 0 && crc == crc16(g.line, len);
  *star = 0;
  on_line(g.line, len, crc_ok);
}

static void uart_out(avr_irq_t *irq, uint32_t value, void *param)
{
  uint8_t c = (uint8_t)value;
  (void)irq; (void)param;
  if (g.out)
    putc(c, g.out);
  g.bytes_out++;
  if (g.pty)
    term_out(c);
  if (g.state == ST_DRAIN) {
    if (c == '\n')
      g.state = ST_DONE;
    return;
  }
  if (c == '$') {
    g.in_line = 1;
    g.line_len = 0;
  } else if (!g.in_line) {
    return;
  } else if (c == '\r' || c == '\n') {
    end_line();
  } else if (g.line_len < LINE_MAX_LEN - 1) {
    g.line[g.line_len++] = (char)c;
  } else {
    g.in_line = 0;
    if (g.bad_frame++ == 0 && !g.pty)
      warn("t=%.6f s: device line longer than %d characters", sim_time(),
           LINE_MAX_LEN);
  }
}

/* ---- measurements ---------------------------------------------------- */

static void pulse(pulse_t *p, uint32_t value)
{
  int lvl = value & 1;
  if (lvl == p->level)
    return;
  p->level = lvl;
  if (lvl) {
    p->rise = g.avr->cycle;
    p->seen_rise = 1;
  } else if (p->seen_rise) {
    uint64_t d = g.avr->cycle - p->rise;
    p->count++;
    p->sum += d;
    if (d > p->max)
      p->max = d;
  }
}

static void pb0_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  (void)irq; (void)param;
  pulse(&g.pb0, value);
}

static void pb1_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  (void)irq; (void)param;
  pulse(&g.pb1, value);
}

static void pb2_notify(avr_irq_t *irq, uint32_t value, void *param)
{
  (void)irq; (void)param;
  pulse(&g.pb2, value);
}

/* Fast: never wait for the wall clock, just count the idle cycles. */
static void no_sleep(avr_t *avr, avr_cycle_count_t how_long)
{
  (void)avr;
  g.slept += how_long + 1;   /* the core then adds 1 + how_long cycles */
}

/* 1 if PATH is an AVR ELF executable. */
static int elf_is_avr(const char *path)
{
  int fd = open(path, O_RDONLY), ok = 0;
  if (fd < 0 || elf_version(EV_CURRENT) == EV_NONE) {
    if (fd >= 0)
      close(fd);
    return 0;
  }
  Elf *e = elf_begin(fd, ELF_C_READ, NULL);
  GElf_Ehdr eh;
  if (e && elf_kind(e) == ELF_K_ELF && gelf_getehdr(e, &eh))
    ok = eh.e_machine == EM_AVR;
  if (e)
    elf_end(e);
  close(fd);
  return ok;
}

/* End of .bss (start of the heap) from the ELF symbol table, or 0. */
static uint16_t elf_bss_end(const char *path)
{
  static const char *const names[] = { "__heap_start", "_end", "__bss_end" };
  uint32_t found[3] = { 0, 0, 0 };
  int fd = open(path, O_RDONLY);
  if (fd < 0 || elf_version(EV_CURRENT) == EV_NONE) {
    if (fd >= 0)
      close(fd);
    return 0;
  }
  Elf *e = elf_begin(fd, ELF_C_READ, NULL);
  Elf_Scn *scn = NULL;
  while (e && (scn = elf_nextscn(e, scn))) {
    GElf_Shdr sh;
    if (!gelf_getshdr(scn, &sh) || sh.sh_type != SHT_SYMTAB || !sh.sh_entsize)
      continue;
    Elf_Data *d = elf_getdata(scn, NULL);
    size_t n = sh.sh_size / sh.sh_entsize;
    for (size_t i = 0; d && i < n; i++) {
      GElf_Sym s;
      if (!gelf_getsym(d, (int)i, &s))
        continue;
      const char *nm = elf_strptr(e, sh.sh_link, s.st_name);
      for (int k = 0; nm && k < 3; k++)
        if (!strcmp(nm, names[k]))
          found[k] = (uint32_t)s.st_value | 0x80000000u;
    }
  }
  if (e)
    elf_end(e);
  close(fd);
  for (int k = 0; k < 3; k++)
    if (found[k])
      return (uint16_t)(found[k] & 0xFFFF);
  return 0;
}

typedef struct {
  int have_stack;
  unsigned stack_used, stack_free, lowest;
} stack_t_;

static stack_t_ stack_mark(void)
{
  stack_t_ s = { 0, 0, 0, 0 };
  avr_t *avr = g.avr;
  if (!avr->data || !g.bss_end || g.bss_end > avr->ramend)
    return s;
  unsigned a = g.bss_end;
  while (a <= avr->ramend && avr->data[a] == PAINT)
    a++;
  s.have_stack = 1;
  s.lowest = a;
  s.stack_used = avr->ramend + 1 - a;
  s.stack_free = a - g.bss_end;
  return s;
}

static avr_io_t *find_io(const char *kind, char name);

static void print_stats(int json)
{
  avr_t *avr = g.avr;
  stack_t_ st = stack_mark();
  double sim_s = sim_time();
  double busy = avr->cycle ? 1.0 - (double)g.slept / (double)avr->cycle : 0.0;
  FILE *f = stderr;
  char smean[32] = "null", imean[32] = "null", smax[32] = "null";
  char imax[32] = "null", dn[32] = "null", dd[32] = "null";
  char sused[32] = "null", sfree[32] = "null", bss[32] = "null";
  char amean[32] = "null", amax[32] = "null";

  if (g.pb0.count) {
    snprintf(smean, sizeof smean, "%.1f", (double)g.pb0.sum / g.pb0.count);
    snprintf(smax, sizeof smax, "%llu", (unsigned long long)g.pb0.max);
  }
  if (g.pb2.count) {
    snprintf(amean, sizeof amean, "%.1f", (double)g.pb2.sum / g.pb2.count);
    snprintf(amax, sizeof amax, "%llu", (unsigned long long)g.pb2.max);
  }
  if (g.pb1.count) {
    snprintf(imean, sizeof imean, "%.1f", (double)g.pb1.sum / g.pb1.count);
    snprintf(imax, sizeof imax, "%llu", (unsigned long long)g.pb1.max);
  }
  if (g.dev_n >= 0)
    snprintf(dn, sizeof dn, "%lld", g.dev_n);
  if (g.dev_drops >= 0)
    snprintf(dd, sizeof dd, "%lld", g.dev_drops);
  if (st.have_stack) {
    snprintf(sused, sizeof sused, "%u", st.stack_used);
    snprintf(sfree, sizeof sfree, "%u", st.stack_free);
  }
  if (g.bss_end)
    snprintf(bss, sizeof bss, "%u", g.bss_end);
  if (json) {
    f = fopen(g.stats_json, "w");
    if (!f) {
      warn("%s: %s", g.stats_json, strerror(errno));
      return;
    }
  }
  struct { const char *key; char val[40]; int text; } kv[40];
  int n = 0;
#define KV(k, ...) \
  (kv[n].key = (k), kv[n].text = 0, \
   snprintf(kv[n].val, sizeof kv[n].val, __VA_ARGS__), n++)
  KV("mcu", "%s", avr->mmcu);
  kv[n - 1].text = 1;
  KV("f_cpu", "%u", avr->frequency);
  if (g.pty && g.synthetic)
    KV("rows", "null");
  else
    KV("rows", "%llu", (unsigned long long)(g.pty ? g.file_rows : g.nrows));
  KV("rows_consumed", "%llu", (unsigned long long)rows_consumed());
  KV("extra_scans", "%llu", (unsigned long long)g.extra_scans);
  KV("extra_conversions", "%llu", (unsigned long long)g.extra_conv);
  KV("sample_count", "%llu", (unsigned long long)g.pb0.count);
  KV("sample_cycles_mean", "%s", smean);
  KV("sample_cycles_max", "%s", smax);
  KV("allan_count", "%llu", (unsigned long long)g.pb2.count);
  KV("allan_cycles_mean", "%s", amean);
  KV("allan_cycles_max", "%s", amax);
  KV("isr_count", "%llu", (unsigned long long)g.pb1.count);
  KV("isr_cycles_mean", "%s", imean);
  KV("isr_cycles_max", "%s", imax);
  /* Whole interrupts, vector to reti (sim_isr.c), not the probe's window. */
  sim_isr_stat_t adc_isr = sim_isr_stat(g.adc->adc.vector), any_isr = sim_isr_all();
  KV("isr_adc_cycles_mean", "%.1f", adc_isr.count ? (double)adc_isr.sum / adc_isr.count : 0.0);
  KV("isr_adc_cycles_max", "%llu", (unsigned long long)adc_isr.max);
  KV("isr_any_cycles_max", "%llu", (unsigned long long)any_isr.max);
  KV("adsc_after_adc_vector_max", "%llu", (unsigned long long)sim_isr_adsc_max(g.adc->adc.vector));
  avr_timer_t *t1 = (avr_timer_t *)find_io("timer", '1');
  KV("adsc_after_tick_max", "%llu",
     (unsigned long long)(t1 ? sim_isr_adsc_max(t1->comp[AVR_TIMER_COMPA].interrupt.vector) : 0));
  KV("cpu_busy_fraction", "%.6f", busy);
  KV("cycles_total", "%llu", (unsigned long long)avr->cycle);
  KV("cycles_slept", "%llu", (unsigned long long)g.slept);
  KV("ram_end", "%u", (unsigned)avr->ramend);
  KV("bss_end", "%s", bss);
  KV("stack_used_bytes", "%s", sused);
  KV("stack_free_bytes", "%s", sfree);
  KV("stack_sp_min", "%u", (unsigned)g.sp_min);
  KV("stack_sp_depth_bytes", "%u", (unsigned)(avr->ramend - g.sp_min));
  KV("stack_deepest_pc", "%lu", (unsigned long)g.sp_min_pc);
  KV("uart_bytes_out", "%llu", (unsigned long long)g.bytes_out);
  KV("uart_bytes_in", "%llu", (unsigned long long)g.bytes_in);
  KV("uart_xoff_events", "%llu", (unsigned long long)g.xoffs);
  KV("bad_crc_lines", "%llu", (unsigned long long)g.bad_crc);
  KV("device_n", "%s", dn);
  KV("device_drops", "%s", dd);
  KV("sim_seconds", "%.6f", sim_s);
  KV("wall_seconds", "%.6f", g.wall_s);
  KV("sim_speed_x", "%.2f", g.wall_s > 0 ? sim_s / g.wall_s : 0.0);
#undef KV
  for (int i = 0; i < n; i++) {
    if (!json)
      fprintf(f, "%s %s\n", kv[i].key, kv[i].val);
    else
      fprintf(f, "%s  \"%s\": %s%s%s", i ? ",\n" : "{\n", kv[i].key,
              kv[i].text ? "\"" : "", kv[i].val, kv[i].text ? "\"" : "");
  }
  if (json)
    fputs("\n}\n", f);
  if (json && fclose(f))
    warn("%s: %s", g.stats_json, strerror(errno));
}

/* ---- command line ---------------------------------------------------- */

static void usage(FILE *f)
{
  fputs(
"Usage: imu-sim [options] --adc FILE ELF\n"
"       imu-sim --pty [--link PATH] (--adc FILE | --synthetic) [--fast] ELF\n"
"\n"
"Run the imu-allan firmware ELF on a simulated AVR (simavr), feed its ADC\n"
"the rows of FILE and capture what it sends on its serial port.  With\n"
"--pty the serial port is a pseudo-terminal instead, for a person or a\n"
"program to drive the device (see Terminal mode below).\n"
"\n"
"What happens (without --pty):\n"
"  1. The firmware boots and samples at once; every conversion reads the\n"
"     neutral code 512 until the harness is armed.\n"
"  2. After the device's boot line ($B) the harness sends 'stop' and waits\n"
"     for its '$ok'; from then on the i-th conversion of ADC mux channel j\n"
"     reads column j of row i, exactly (j = 0..6: ax ay az gx gy gz temp).\n"
"  3. It sends 'rate HZ' (with --fs), 'reset' and 'start R', R being the\n"
"     number of rows, each after the previous one's '$ok'.\n"
"  4. Once mux 6 of the last row was converted, it sends 'report', waits\n"
"     for the end line ($E) of the report that follows the reply and\n"
"     exits 0.  Conversions after the last row read the last row again and\n"
"     are reported as a warning (the device dropped samples).\n"
"Host bytes go to the device at the firmware's baud rate (one byte time\n"
"each), honouring simavr's receive FIFO flow control.  Simulated time\n"
"runs as fast as the host can go; idle (sleep) time costs nothing.\n"
"\n"
"Options:\n"
"  --adc FILE        ADC rows, '-' for stdin (required without --pty).  One\n"
"                    row per line: 7 integer codes 0..1023 separated by\n"
"                    tabs or spaces; blank lines, '#' comments (whole line\n"
"                    or trailing) and lines starting with '$' (the count\n"
"                    lines and replies in a capture of the device's 'mode\n"
"                    raw' output, which replays as is) are skipped.  The whole\n"
"                    file is checked before the simulation starts (stdin is\n"
"                    copied to a temporary file for that); a bad row stops\n"
"                    with 'imu-sim: FILE:LINE: reason' (LINE: line number\n"
"                    in the file) and exit status 2.  Codes of mux channels\n"
"                    other than 0..6 read 0 (with a warning).\n"
"  --fs HZ           send 'rate HZ' before 'reset' (default: firmware's rate)\n"
"  --uart-in FILE    timed host input ('-' for stdin).  Lines\n"
"                    '<N><TAB><text>': text is sent once N rows have been\n"
"                    consumed, i.e. mux 6 of row N-1 was converted (N=0:\n"
"                    right after 'start' was acknowledged); N must not\n"
"                    decrease from line to line.\n"
"                    Text is sent as is, with escapes \\r \\n \\t \\\\ \\xNN;\n"
"                    end a command with \\r yourself (e.g. '500<TAB>report\\r').\n"
"                    '#' lines and blank lines are skipped.  Replies to these\n"
"                    commands are only captured, never acted upon.\n"
"  -o, --output FILE everything the device sends, bytes as they are\n"
"                    (default: stdout)\n"
"  --mcu NAME        MCU (default: from the ELF's .mmcu section, else\n"
"                    atmega168)\n"
"  --freq HZ         CPU clock (default: from .mmcu, else 10000000)\n"
"  --timeout SEC     simulated seconds to wait for each expected line, and\n"
"                    for each row while sampling (default 5)\n"
"  --stats           print measured figures on stderr, one 'key value' a line\n"
"  --stats-json FILE the same figures as a JSON object in FILE\n"
"                    (--stats=FILE is the same as --stats-json FILE)\n"
"  -v, --verbose     show simavr's own output and all its warnings;\n"
"                    -vv adds simavr trace messages\n"
"  -h, --help        this text\n"
"\n"
"Terminal mode:\n"
"  --pty             the device's serial port on a new pseudo-terminal; its\n"
"                    path goes to stdout ('imu-sim: device on /dev/pts/N').\n"
"                    The harness sends no command of its own: the firmware\n"
"                    boots, samples at its defaults and answers whoever\n"
"                    writes to the terminal (picocom -b 115200 PATH,\n"
"                    imu-allan monitor --port PATH, pyserial; the baud\n"
"                    rate set on the terminal does not matter).  Every\n"
"                    conversion reads the next input row, from the first.\n"
"                    The device powers up when a terminal first opens the\n"
"                    port (0.2 s later, so that it sees the boot line), and\n"
"                    runs until SIGINT, SIGTERM or SIGHUP (exit 0); a\n"
"                    terminal may close and open it again meanwhile.\n"
"                    What the device sends while no terminal is open is\n"
"                    lost, as on a serial line with nothing attached.\n"
"                    Typed or pasted bytes reach the device one byte time\n"
"                    apart at the firmware's baud rate, honouring simavr's\n"
"                    receive FIFO flow control; a long paste waits in the\n"
"                    pty, not in the device.\n"
"  --link PATH       also make a symbolic link PATH -> the pty (replacing a\n"
"                    symlink already there); removed at exit\n"
"  --adc FILE        rows as above, served in order and again from the\n"
"                    first row after the last\n"
"  --synthetic       rows from a built-in IMU instead: seeded white noise,\n"
"                    codes ax ay az gx gy gz temp around 498 494 791 520\n"
"                    497 498 63, sigma 2.0 2.5 1.7 0.9 0.67 0.57 0.5 counts\n"
"  --seed N          seed of --synthetic (default 1)\n"
"  --realtime        simulated time follows the wall clock, idle time too:\n"
"                    100 Hz is 100 samples a second, a 60 s report interval\n"
"                    is a minute (default).  A host too slow for that\n"
"                    gets a warning, and simulated time falls behind.\n"
"  --fast            simulated time runs as fast as the host can go (some\n"
"                    200 times real time while sampling); device output\n"
"                    then waits for the terminal to read it, instead of\n"
"                    being lost when it does not\n"
"  --no-wait         power up at once, not when a terminal opens the port\n"
"  --eeprom FILE     EEPROM contents at power-up, from address 0 (raw bytes;\n"
"                    the rest reads 0xFF, as on a blank chip)\n"
"  -o FILE           also keep a copy of everything the device sends\n"
"  --fs, --uart-in and --timeout do not apply.\n"
"\n"
"Figures (--stats):\n"
"  sample_cycles_mean/max, sample_count  CPU cycles PB0 stays high (the\n"
"                    firmware raises it while it handles one sample set)\n"
"  isr_cycles_mean/max, isr_count        the same for PB1 (ADC interrupt)\n"
"  isr_adc_cycles_mean/max, isr_any_cycles_max  whole interrupts, from the\n"
"                    jump to the vector to the end of reti: the ADC's,\n"
"                    and the longest of any vector\n"
"  adsc_after_adc_vector_max, adsc_after_tick_max  cycles from the ADC's\n"
"                    (Timer1 COMPA's) vector to the ADSC its ISR writes\n"
"  allan_cycles_mean/max, allan_count    the same for PB2 (high around each\n"
"                                        call into the Allan engine)\n"
"  cpu_busy_fraction 1 - slept cycles / total cycles\n"
"  stack_used_bytes, stack_free_bytes    SRAM is filled with 0xA5 before the\n"
"                    run; the lowest overwritten byte above the end of .bss\n"
"                    (__heap_start, else _end) marks the deepest stack;\n"
"                    free = bytes between the end of .bss and that byte\n"
"  stack_sp_min, stack_sp_depth_bytes    lowest stack pointer seen (checked\n"
"                    after every instruction) and RAMEND minus it: counts\n"
"                    reserved but unwritten frames too; below .bss = overflow\n"
"  sim_seconds, wall_seconds, sim_speed_x  simulated and host time of the\n"
"                    simulation, and their ratio\n"
"  rows_consumed, extra_scans, device_n, device_drops (from the final $H),\n"
"  uart_bytes_in/out, uart_xoff_events (simavr's receive FIFO was full),\n"
"  bad_crc_lines, cycles_total, cycles_slept\n"
"  Unmeasured figures are null.\n"
"\n"
"Exit status: 0 done; 1 firmware crash or halt, device error reply, or\n"
"another run failure; 2 bad command line or input file; 3 the device did\n"
"not answer within --timeout simulated seconds.  Failures print one line.\n"
"With --pty: 0 after SIGINT, SIGTERM or SIGHUP; 1 firmware crash or halt,\n"
"or no pty; 2 bad command line, input file or --link PATH.\n",
      f);
}

static unsigned long parse_ulong(const char *s, const char *opt)
{
  char *end;
  errno = 0;
  unsigned long v = strtoul(s, &end, 0);
  if (!*s || *end || errno || *s == '-')
    die(EXIT_INPUT, "%s: '%s' is not a positive integer (see --help)", opt, s);
  return v;
}

static void parse_args(int argc, char **argv)
{
  enum { O_ADC = 256, O_FS, O_UART_IN, O_MCU, O_FREQ, O_TIMEOUT, O_STATS,
         O_STATS_JSON, O_PTY, O_LINK, O_SYNTHETIC, O_SEED, O_REALTIME, O_FAST,
         O_NO_WAIT, O_EEPROM };
  static const struct option opts[] = {
    { "adc", required_argument, NULL, O_ADC },
    { "fs", required_argument, NULL, O_FS },
    { "uart-in", required_argument, NULL, O_UART_IN },
    { "output", required_argument, NULL, 'o' },
    { "mcu", required_argument, NULL, O_MCU },
    { "freq", required_argument, NULL, O_FREQ },
    { "timeout", required_argument, NULL, O_TIMEOUT },
    { "stats", optional_argument, NULL, O_STATS },
    { "stats-json", required_argument, NULL, O_STATS_JSON },
    { "pty", no_argument, NULL, O_PTY },
    { "link", required_argument, NULL, O_LINK },
    { "synthetic", no_argument, NULL, O_SYNTHETIC },
    { "seed", required_argument, NULL, O_SEED },
    { "realtime", no_argument, NULL, O_REALTIME },
    { "fast", no_argument, NULL, O_FAST },
    { "no-wait", no_argument, NULL, O_NO_WAIT },
    { "eeprom", required_argument, NULL, O_EEPROM },
    { "verbose", no_argument, NULL, 'v' },
    { "help", no_argument, NULL, 'h' },
    { NULL, 0, NULL, 0 },
  };
  int c;
  opterr = 0;
  while ((c = getopt_long(argc, argv, ":o:vh", opts, NULL)) != -1) {
    switch (c) {
    case O_ADC: g.adc_path = optarg; break;
    case O_FS: g.fs = (unsigned)parse_ulong(optarg, "--fs"); break;
    case O_UART_IN: g.uart_in_path = optarg; break;
    case 'o': g.out_path = optarg; break;
    case O_MCU: g.mcu = optarg; break;
    case O_FREQ: g.freq = (uint32_t)parse_ulong(optarg, "--freq"); break;
    case O_TIMEOUT: {
      char *end;
      g.timeout_s = strtod(optarg, &end);
      g.timeout_set = 1;
      if (*end || !(g.timeout_s > 0))
        die(EXIT_INPUT, "--timeout: '%s' is not a positive number of seconds",
            optarg);
      break;
    }
    case O_STATS:
      if (optarg)
        g.stats_json = optarg;
      else
        g.stats_text = 1;
      break;
    case O_STATS_JSON: g.stats_json = optarg; break;
    case O_PTY: g.pty = 1; break;
    case O_LINK: g.link_path = optarg; break;
    case O_SYNTHETIC: g.synthetic = 1; break;
    case O_SEED: g.seed = parse_ulong(optarg, "--seed"); break;
    case O_REALTIME: g.realtime = 1; break;
    case O_FAST: g.fast = 1; break;
    case O_NO_WAIT: g.no_wait = 1; break;
    case O_EEPROM: g.eeprom_path = optarg; break;
    case 'v': g.verbose++; break;
    case 'h': usage(stdout); exit(EXIT_OK);
    case ':': die(EXIT_INPUT, "%s needs an argument (see --help)", argv[optind - 1]);
    default: die(EXIT_INPUT, "unknown option '%s' (see --help)", argv[optind - 1]);
    }
  }
  if (optind == argc)
    die(EXIT_INPUT, "missing the firmware ELF file (see --help)");
  if (optind != argc - 1)
    die(EXIT_INPUT, "expected one ELF file, got %d arguments (see --help)",
        argc - optind);
  g.elf_path = argv[optind];
  if (!g.pty) {
    const char *only = g.link_path ? "--link" : g.synthetic ? "--synthetic" :
      g.fast ? "--fast" : g.realtime ? "--realtime" : g.no_wait ? "--no-wait" :
      g.seed != 1 ? "--seed" : NULL;
    if (only)
      die(EXIT_INPUT, "%s only applies with --pty (see --help)", only);
  } else {
    const char *not = g.fs ? "--fs" : g.uart_in_path ? "--uart-in" :
      g.timeout_set ? "--timeout" : NULL;
    if (not)
      die(EXIT_INPUT, "%s does not apply with --pty: the terminal drives "
          "the device (see --help)", not);
    if (g.fast && g.realtime)
      die(EXIT_INPUT, "--fast and --realtime exclude each other");
    if (g.synthetic && g.adc_path)
      die(EXIT_INPUT, "--adc and --synthetic exclude each other");
    if (!g.synthetic && !g.adc_path)
      die(EXIT_INPUT, "--pty needs --adc FILE or --synthetic (see --help)");
    return;
  }
  if (!g.adc_path)
    die(EXIT_INPUT, "--adc FILE is required (see --help)");
  if (g.fs && g.fs > 100000)
    die(EXIT_INPUT, "--fs: %u Hz is not a sample rate", g.fs);
  if (g.uart_in_path && !strcmp(g.uart_in_path, "-") && !strcmp(g.adc_path, "-"))
    die(EXIT_INPUT, "--adc and --uart-in cannot both read stdin");
}

static avr_io_t *find_io(const char *kind, char name)
{
  for (avr_io_t *io = g.avr->io_port; io; io = io->next)
    if (io->kind && !strcmp(io->kind, kind) &&
        (!name || ((avr_uart_t *)io)->name == name))
      return io;
  return NULL;
}

/* The lowest stack pointer, checked after every instruction. */
static inline void watch_sp(void)
{
  avr_t *avr = g.avr;
  uint16_t sp = (uint16_t)(avr->data[R_SPL] | avr->data[R_SPH] << 8);
  if (sp < g.sp_min) {
    g.sp_min = sp;
    g.sp_min_pc = avr->pc;
  }
  sim_isr_step();
}

/* Real time: a timer every slice, so that a sleeping device never skips
 * more than a slice of simulated time at once (simavr jumps a sleeping
 * CPU to its next timer event, which for a stopped device can be far
 * away), and a byte typed meanwhile reaches it within a slice. */
static avr_cycle_count_t term_tick(avr_t *avr, avr_cycle_count_t when, void *param)
{
  (void)avr; (void)param;
  return when + t.slice;
}

static void term_cleanup(void)
{
  pty_close(&t.pty);
}

static void on_stop_signal(int sig)
{
  stop_signal = sig;
}

/* A terminal needs a moment after open() to set its line up and flush
 * its input (pyserial, picocom do): the device powers up after that, so
 * that the terminal sees the boot line. */
#define OPEN_GRACE_S 0.2

/* Terminal mode: the device runs until a signal (or a crash); the user
 * drives it from the terminal.  Returns the last avr_run() state. */
static int term_run(void)
{
  avr_t *avr = g.avr;
  struct sigaction sa;
  int readable, st = cpu_Running;

  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_stop_signal;     /* no SA_RESTART: sleeps end early */
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, NULL);
  sigaction(SIGTERM, &sa, NULL);
  sigaction(SIGHUP, &sa, NULL);
  signal(SIGPIPE, SIG_IGN);

  fprintf(t.info, PROG ": device on %s\n", t.pty.slave);
  if (t.pty.link)
    fprintf(t.info, PROG ": linked as %s\n", t.pty.link);
  fflush(t.info);
  if (!g.no_wait) {
    fprintf(stderr, PROG ": the device powers up when a terminal opens it "
            "(%s%s, %s; Ctrl-C ends)\n",
            g.synthetic ? "synthetic IMU" : "ADC rows from ",
            g.synthetic ? "" : g.adc_path, g.fast ? "fast" : "real time");
    while (!stop_signal && !pty_state(&t.pty, &readable))
      sleep_s(0.01);
    sleep_s(OPEN_GRACE_S);
  }

  t.slice = avr->frequency / (g.fast ? 200 : 1000);   /* 5 or 1 ms */
  clock_gettime(CLOCK_MONOTONIC, &t.t0);
  t.c0 = avr->cycle;
  t.next_io = avr->cycle + t.slice;
  if (!g.fast)
    avr_cycle_timer_register(avr, t.slice, term_tick, NULL);
  term_poll();
  while (!stop_signal && !g.fail) {
    st = avr_run(avr);
    if (st == cpu_Crashed || st == cpu_Done || st == cpu_Stopped)
      break;
    watch_sp();
    if (avr->cycle < t.next_io)
      continue;
    t.next_io = avr->cycle + t.slice;
    term_flush();
    term_poll();
    if (!g.fast)
      term_pace();
  }
  if (st != cpu_Done)
    term_flush();
  return st;
}

int main(int argc, char **argv)
{
  char err[320];
  elf_firmware_t fw;

  parse_args(argc, argv);

  /* Inputs are checked before anything is simulated. */
  if (g.adc_path && rows_open(&g.rows, g.adc_path, &g.nrows, err, sizeof err))
    die(EXIT_INPUT, "%s", err);
  if (g.pty) {
    /* rows go round and round: no end */
    g.file_rows = g.nrows;
    g.nrows = UINT64_MAX;
    if (g.synthetic)
      synth_init(&g.synth, g.seed);
  }
  if (g.uart_in_path) {
    g.nuin = uart_in_load(g.uart_in_path, &g.uin, err, sizeof err);
    if (g.nuin < 0)
      die(EXIT_INPUT, "%s", err);
  }
  if (access(g.elf_path, R_OK))
    die(EXIT_INPUT, "%s: %s", g.elf_path, strerror(errno));
  if (!elf_is_avr(g.elf_path))
    die(EXIT_INPUT, "%s: not an AVR ELF file", g.elf_path);
  if (g.pty) {
    int fd = dup(STDOUT_FILENO);
    t.info = fd < 0 ? NULL : fdopen(fd, "w");
    if (!t.info)
      die(EXIT_FAIL, "stdout: %s", strerror(errno));
    int r = pty_open(&t.pty, g.link_path, err, sizeof err);
    if (r)
      die(r == -2 ? EXIT_INPUT : EXIT_FAIL, "%s", err);
    atexit(term_cleanup);     /* the link goes, however imu-sim ends */
  }

  /* Serial output goes to the real stdout (or -o; in terminal mode to the
   * pty, and to -o if given); simavr's own printf chatter on fd 1 goes to
   * /dev/null (stderr with -v). */
  if (g.pty && !g.out_path) {
    g.out = NULL;
  } else if (g.out_path) {
    g.out = fopen(g.out_path, "wb");
    if (!g.out)
      die(EXIT_INPUT, "%s: %s", g.out_path, strerror(errno));
  } else {
    int fd = dup(STDOUT_FILENO);
    g.out = fd < 0 ? NULL : fdopen(fd, "wb");
    if (!g.out)
      die(EXIT_FAIL, "stdout: %s", strerror(errno));
  }
  if (g.out)
    setvbuf(g.out, NULL, _IOFBF, 1 << 16);
  fflush(stdout);
  int chatter = g.verbose ? dup(STDERR_FILENO) : open("/dev/null", O_WRONLY);
  if (chatter >= 0) {
    dup2(chatter, STDOUT_FILENO);
    close(chatter);
  }

  avr_global_logger_set(logger);
  memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(g.elf_path, &fw) || !fw.flashsize)
    die(EXIT_INPUT, "%s: no firmware could be loaded from this ELF", g.elf_path);
  if (g.mcu)
    snprintf(fw.mmcu, sizeof fw.mmcu, "%s", g.mcu);
  else if (!fw.mmcu[0])
    snprintf(fw.mmcu, sizeof fw.mmcu, "%s", "atmega168");
  if (g.freq)
    fw.frequency = g.freq;
  else if (!fw.frequency)
    fw.frequency = 10000000;
  fw.avcc = fw.aref = 1023;   /* mV == code, see code_to_mv() */

  g.log_quiet = 1;
  g.avr = avr_make_mcu_by_name(fw.mmcu);
  g.log_quiet = 0;
  if (!g.avr)
    die(EXIT_INPUT, "unknown MCU '%s'", fw.mmcu);
  avr_t *avr = g.avr;
  avr_init(avr);
  avr_load_firmware(avr, &fw);
  avr->avcc = avr->aref = 1023;
  avr->log = g.verbose >= 2 ? LOG_TRACE : LOG_WARNING;
  avr->sleep = no_sleep;
  g.timeout_cycles = (avr_cycle_count_t)(g.timeout_s * avr->frequency);
  set_state(ST_BOOT);

  g.adc = (avr_adc_t *)find_io("adc", 0);
  g.uart = (avr_uart_t *)find_io("uart", '0');
  if (!g.adc || !g.uart)
    die(EXIT_INPUT, "MCU '%s' has no ADC or no UART0 in simavr", fw.mmcu);
  g.adc_irq = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, 0);
  g.uart_irq = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), 0);
  avr_irq_register_notify(g.adc_irq + ADC_IRQ_OUT_TRIGGER, adc_trigger, NULL);
  sim_isr_watch(avr);
  avr_irq_register_notify(g.uart_irq + UART_IRQ_OUTPUT, uart_out, NULL);
  avr_irq_register_notify(g.uart_irq + UART_IRQ_OUT_XON, xon_notify, NULL);
  avr_irq_register_notify(g.uart_irq + UART_IRQ_OUT_XOFF, xoff_notify, NULL);
  avr_irq_t *pb = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), 0);
  if (pb) {
    avr_irq_register_notify(pb + IOPORT_IRQ_PIN0, pb0_notify, NULL);
    avr_irq_register_notify(pb + IOPORT_IRQ_PIN1, pb1_notify, NULL);
    avr_irq_register_notify(pb + IOPORT_IRQ_PIN2, pb2_notify, NULL);
  }
  uint32_t flags = 0;
  avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
  flags &= ~(uint32_t)(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
  avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);

  /* EEPROM contents at power-up (--eeprom): saved settings, blank or not. */
  if (g.eeprom_path) {
    uint8_t ee[4096];
    FILE *f = fopen(g.eeprom_path, "rb");
    if (!f)
      die(EXIT_INPUT, "--eeprom: cannot read '%s': %s", g.eeprom_path, strerror(errno));
    size_t n = fread(ee, 1, sizeof ee, f);
    fclose(f);
    if (n > avr->e2end + 1u)
      die(EXIT_INPUT, "--eeprom: '%s' has %zu bytes, the %s's EEPROM %u",
          g.eeprom_path, n, avr->mmcu, (unsigned)(avr->e2end + 1u));
    if (n) {
      avr_eeprom_desc_t d = { .ee = ee, .offset = 0, .size = (uint32_t)n };
      avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d);
    }
  }

  /* Paint SRAM for the stack high-water mark (the startup code then
   * writes .data and .bss over their part). */
  g.bss_end = elf_bss_end(g.elf_path);
  if (!g.bss_end)
    g.bss_end = (uint16_t)(avr->ioend + 1 + fw.datasize + fw.bsssize);
  for (unsigned a = avr->ioend + 1u; a <= avr->ramend; a++)
    avr->data[a] = PAINT;

  struct timespec t0, t1;
  clock_gettime(CLOCK_MONOTONIC, &t0);
  int st = cpu_Running;
  if (g.pty) {
    /* The user drives the device: conversions read rows from the start. */
    g.state = ST_TERM;
    g.armed = 1;
    st = term_run();
    t0 = t.t0;    /* wall time from power-up, not from the wait */
  }
  while (!g.pty && g.state != ST_DONE && !g.fail) {
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
  clock_gettime(CLOCK_MONOTONIC, &t1);
  g.wall_s = (double)(t1.tv_sec - t0.tv_sec) + (t1.tv_nsec - t0.tv_nsec) * 1e-9;
  if (g.out)
    fflush(g.out);

  int code = EXIT_OK;
  if (st == cpu_Crashed || st == cpu_Stopped) {
    snprintf(g.fail_msg, sizeof g.fail_msg, "the firmware crashed at t=%.6f s "
             "(cycle %llu, PC 0x%04x)%s%s", sim_time(),
             (unsigned long long)avr->cycle, (unsigned)avr->pc,
             g.last_error[0] ? ": " : "", g.last_error);
    code = EXIT_FAIL;
  } else if (st == cpu_Done) {
    /* simavr has already freed the AVR's memories here. */
    snprintf(g.fail_msg, sizeof g.fail_msg, "the firmware halted at t=%.6f s "
             "(cycle %llu): sleep with interrupts disabled", sim_time(),
             (unsigned long long)avr->cycle);
    code = EXIT_FAIL;
  } else if (g.fail) {
    code = g.fail;
  }

  if (g.errors && st != cpu_Crashed && st != cpu_Stopped)
    warn("simavr reported %llu error(s), the last: %s",
         (unsigned long long)g.errors, g.last_error);
  if (g.bss_end && g.sp_min < g.bss_end)
    warn("stack overflow: the stack pointer went down to 0x%04x, below the "
         "end of .bss at 0x%04x", (unsigned)g.sp_min, (unsigned)g.bss_end);
  if (g.pty) {
    if (t.dropped)
      warn("%llu device bytes were lost: the terminal did not read them",
           (unsigned long long)t.dropped);
    if (g.bytes_lost)
      warn("%llu bytes from the terminal were lost: the device's receiver "
           "was disabled", (unsigned long long)g.bytes_lost);
    if (st != cpu_Crashed && st != cpu_Stopped && st != cpu_Done)
      fprintf(stderr, PROG ": stopped at t=%.1f simulated s (%.1f s of wall "
              "time); %llu bytes from the terminal, %llu to it\n",
              sim_time(), g.wall_s, (unsigned long long)t.from_term,
              (unsigned long long)(g.bytes_out - t.unheard - t.dropped));
  } else {
    /* about a run the harness drove */
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

  if (g.stats_text && st != cpu_Done)
    print_stats(0);
  if (g.stats_json && st != cpu_Done)
    print_stats(1);
  if (code != EXIT_OK)
    fprintf(stderr, PROG ": %s\n", g.fail_msg);
  pty_close(&t.pty);
  if (g.out && fclose(g.out))
    die(EXIT_FAIL, "%s: %s", g.out_path ? g.out_path : "stdout", strerror(errno));
  rows_close(&g.rows);
  uart_in_free(g.uin, g.nuin);
  if (st != cpu_Done)
    avr_terminate(avr);
  return code;
}
