/*
 * sim_termrun.c - terminal mode (--pty): the device's serial port on a
 * pseudo-terminal for a person or a program, simulated time paced to the
 * wall clock (or --fast), device output lost while no terminal listens.
 */
#define _GNU_SOURCE
#include "sim_termrun.h"
#include "sim_regbit.h"

#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "sim_board.h"
#include "sim_fault.h"
#include "sim_msg.h"
#include "sim_serial.h"

/* Set by SIGINT, SIGTERM, SIGHUP: the terminal loop ends. */
static volatile sig_atomic_t stop_signal;

static struct {
  pty_t pty;
  FILE *info;         /* the real stdout: the device path */
  int connected;      /* a terminal has the slave open */
  uint8_t obuf[4096]; /* device bytes not yet written to the master */
  size_t olen;
  uint64_t unheard;   /* bytes sent while no terminal was open */
  uint64_t dropped;   /* bytes the terminal did not read in time */
  uint64_t from_term; /* bytes read from the terminal */
  uint64_t resyncs;   /* times the host fell behind real time */
  uint64_t flushed;   /* host bytes lost to a closed line or a reset */
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
  nanosleep(&ts, NULL); /* a signal ends it early: fine */
}

/* Is a terminal there?  Reads what it typed while the harness has room
 * for it: the rest waits in the pty, so a long paste blocks its writer
 * instead of piling up here.  Bytes go to the device paced at the baud
 * rate, honouring the receive FIFO's flow control (tx_push). */
/* Bytes from a terminal that closed, or sent to an MCU that was reset
 * meanwhile, never arrive (its UART restarts empty): a next session must
 * not receive the end of the last one (say, half a page of an upload that
 * was cut off, which would throw the bootloader out of step). */
static void drop_host_bytes(harness_t *h)
{
  uint8_t buf[256];
  t.flushed += serial_drop_queued(h);
  for (;;) { /* what the closed terminal left in the pty */
    ssize_t n = read(t.pty.master, buf, sizeof buf);
    if (n <= 0 && !(n < 0 && errno == EINTR))
      break;
    if (n > 0)
      t.flushed += (uint64_t)n;
  }
}

static void term_poll(harness_t *h)
{
  int readable;
  int now = pty_state(&t.pty, &readable);
  int opened = h->board ? pty_opened(&t.pty) : 0;
  if (now != t.connected || opened > 0) {
    if (h->verbose)
      fprintf(stderr, PROG ": t=%.3f s: terminal %s\n", sim_time(h),
              now ? "opened" : "closed");
    if (!now || opened > 0)
      drop_host_bytes(h); /* they went with the last line */
    /* DTR auto-reset: every open, even a close and open between two
     * looks (inotify counts them); without inotify, a change seen */
    if (h->board && (opened > 0 || (opened < 0 && now && !t.connected))) {
      board_external_reset(h);
      now = pty_state(&t.pty, &readable);
    }
    t.connected = now;
  }
  /* Typed bytes wait in the pty until the firmware has enabled its
   * receiver: the device powers up when the terminal opens it (as a board
   * reset by DTR does), and a command sent at once would otherwise reach
   * a UART not yet listening and be lost without a reply. */
  if (!avr_regbit_get(h->avr, h->uart->rxen))
    return;
  while (t.connected && readable && serial_queued(h) < 64) {
    uint8_t buf[64];
    ssize_t n = read(t.pty.master, buf, sizeof buf - serial_queued(h));
    if (n > 0) {
      t.from_term += (uint64_t)n;
      serial_push(h, buf, (size_t)n);
      continue;
    }
    if (n < 0 && errno == EINTR)
      continue;
    if (n < 0 && errno != EAGAIN)
      t.connected = 0; /* EIO: the terminal went away */
    break;
  }
}

/* Device bytes to the terminal.  With no terminal they are lost, as on a
 * serial line with nothing attached.  A terminal that does not read:
 * real time drops what does not fit (the device cannot wait); --fast
 * waits for it, since simulated time can. */
static void term_flush(harness_t *h)
{
  size_t off = 0;
  if (h->out && t.olen)
    fflush(h->out); /* -o: a copy others may read while the device runs */
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
    if (!h->fast || stop_signal) {
      if (!t.dropped)
        warn("t=%.3f s: the terminal does not read: device output is lost",
             sim_time(h));
      t.dropped += t.olen - off;
      break;
    }
    struct pollfd q = { .fd = t.pty.master, .events = POLLOUT };
    if (poll(&q, 1, 100) > 0 && (q.revents & (POLLHUP | POLLERR)))
      t.connected = 0;
  }
  t.olen = 0;
}

static void term_out(harness_t *h, uint8_t c)
{
  t.obuf[t.olen++] = c;
  if (t.olen == sizeof t.obuf)
    term_flush(h);
}

/* Real time: hold the simulation until the wall clock catches up with
 * it, serving the terminal meanwhile.  A host too slow for real time
 * restarts the comparison rather than rushing to catch up. */
static void term_pace(harness_t *h)
{
  for (;;) {
    double ahead =
        (double)(h->avr->cycle - t.c0) / h->avr->frequency - since(&t.t0);
    if (ahead < -0.25) {
      if (!t.resyncs++)
        warn("t=%.3f s: the host cannot keep up with real time; "
             "simulated time runs slower",
             sim_time(h));
      clock_gettime(CLOCK_MONOTONIC, &t.t0);
      t.c0 = h->avr->cycle;
      return;
    }
    if (ahead <= 0 || stop_signal)
      return;
    if (t.connected && serial_queued(h) < 64) {
      /* wake up early for typed bytes */
      struct pollfd q = { .fd = t.pty.master, .events = POLLIN };
      struct timespec ts = { 0, (long)(ahead * 1e9) };
      if (ppoll(&q, 1, &ts, NULL) > 0)
        term_poll(h);
      if (!t.connected)
        sleep_s(ahead);
    } else {
      sleep_s(ahead);
    }
  }
}

/* Real time: a timer every slice, so that a sleeping device never skips
 * more than a slice of simulated time at once (simavr jumps a sleeping
 * CPU to its next timer event, which for a stopped device can be far
 * away), and a byte typed meanwhile reaches it within a slice. */
static avr_cycle_count_t term_tick(avr_t *avr, avr_cycle_count_t when,
                                   void *param)
{
  (void)avr;
  (void)param;
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
/* After any reset simavr has dropped the cycle timers (and newer simavr
 * versions restart the cycle count from 0; 1.6 goes on counting): the
 * harness re-arms its timers, and re-bases the real-time comparison if
 * the count went back. */
static void term_after_reset(harness_t *h)
{
  avr_t *avr = h->avr;
  h->reset_seen = 0;
  t.flushed += serial_drop_queued(h); /* bytes on the wire during the reset */
  if (avr->cycle < t.c0) {
    clock_gettime(CLOCK_MONOTONIC, &t.t0);
    t.c0 = avr->cycle;
  }
  t.next_io = avr->cycle + t.slice;
  if (!h->fast)
    avr_cycle_timer_register(avr, t.slice, term_tick, NULL);
  serial_after_reset(h);
}

/* Board mode: a chip does not stop on an opcode simavr cannot run (a
 * half-written firmware, say); it goes astray until it is reset.  The board
 * waits for a reset (the port opened) and runs on. */
static int term_stuck(harness_t *h)
{
  avr_t *avr = h->avr;
  warn("t=%.3f s: the firmware crashed (PC 0x%04x)%s%s; the board is stuck "
       "until it is reset (open the port)",
       sim_time(h), (unsigned)avr->pc, h->last_error[0] ? ": " : "",
       h->last_error);
  while (!stop_signal && avr->state != cpu_Running) {
    sleep_s(0.001);
    term_flush(h);
    term_poll(h);
    board_poll(h);
  }
  if (h->reset_seen)
    term_after_reset(h);
  return avr->state;
}

/* Device lines are only watched for a reboot: bad lines are the user's
 * business (and binary frames look like garbage). */
static void on_line(harness_t *h, char *body, size_t len, int crc_ok)
{
  (void)len;
  if (!crc_ok)
    h->bad_crc++;
  if (!strncmp(body, "B,", 2) && h->boots++ && !h->board)
    warn("t=%.6f s: the device rebooted (boot line #%llu)", sim_time(h),
         (unsigned long long)h->boots);
}

int term_run(harness_t *h)
{
  avr_t *avr = h->avr;
  struct sigaction sa;
  int readable, st = cpu_Running;

  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_stop_signal; /* no SA_RESTART: sleeps end early */
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, NULL);
  sigaction(SIGTERM, &sa, NULL);
  sigaction(SIGHUP, &sa, NULL);
  signal(SIGPIPE, SIG_IGN);

  h->on_byte = term_out;
  h->fault.link_on = 1; /* the whole session goes over the link */
  h->on_line = on_line;
  fprintf(t.info, PROG ": device on %s\n", t.pty.slave);
  if (t.pty.link)
    fprintf(t.info, PROG ": linked as %s\n", t.pty.link);
  fflush(t.info);
  if (!h->no_wait) {
    fprintf(stderr,
            PROG ": the device powers up when a terminal opens it "
                 "(%s%s, %s; Ctrl-C ends)\n",
            h->synthetic ? "synthetic IMU" : "ADC rows from ",
            h->synthetic ? "" : h->adc_path, h->fast ? "fast" : "real time");
    while (!stop_signal && !pty_state(&t.pty, &readable))
      sleep_s(0.01);
    sleep_s(OPEN_GRACE_S);
  }

  t.slice = avr->frequency / (h->fast ? 200 : 1000); /* 5 or 1 ms */
  clock_gettime(CLOCK_MONOTONIC, &t.t0);
  t.c0 = avr->cycle;
  t.next_io = avr->cycle + t.slice;
  if (!h->fast)
    avr_cycle_timer_register(avr, t.slice, term_tick, NULL);
  h->reset_seen = 0;
  term_poll(h);
  if (h->reset_seen)
    term_after_reset(h);
  unsigned slices = 0;
  while (!stop_signal && !h->fail) {
    st = avr_run(avr);
    if (h->board && (st == cpu_Crashed || st == cpu_Stopped))
      st = term_stuck(h);
    if (st == cpu_Crashed || st == cpu_Done || st == cpu_Stopped)
      break;
    watch_sp(h);
    if (avr->cycle >= h->fault.next_at && fault_poll(h))
      h->reset_seen = 1;
    if (h->reset_seen)
      term_after_reset(h);
    if (avr->cycle < t.next_io)
      continue;
    t.next_io = avr->cycle + t.slice;
    term_flush(h);
    term_poll(h);
    if (h->reset_seen)
      term_after_reset(h);
    if (h->board && ++slices % 50 == 0)
      board_poll(h); /* every 50 ms (250 ms with --fast) */
    if (!h->fast)
      term_pace(h);
  }
  if (st != cpu_Done)
    term_flush(h);
  return st;
}

void term_open(harness_t *h)
{
  char err[320];
  int fd = dup(STDOUT_FILENO);
  t.info = fd < 0 ? NULL : fdopen(fd, "w");
  if (!t.info)
    die(EXIT_FAIL, "stdout: %s", strerror(errno));
  int r = pty_open(&t.pty, h->link_path, err, sizeof err);
  if (r)
    die(r == -2 ? EXIT_INPUT : EXIT_FAIL, "%s", err);
  atexit(term_cleanup); /* the link goes, however imu-sim ends */
  if (h->board && pty_opened(&t.pty) < 0) /* start counting opens */
    warn("no inotify on %s: a close and open faster than a millisecond "
         "may not reset the board",
         t.pty.slave);
}

void term_started(struct timespec *t0)
{
  *t0 = t.t0;
}

void term_summary(harness_t *h, int st)
{
  if (h->verbose && t.flushed)
    fprintf(stderr,
            PROG ": %llu bytes from the terminal were lost to a reset "
                 "or a closed line\n",
            (unsigned long long)t.flushed);
  if (t.dropped)
    warn("%llu device bytes were lost: the terminal did not read them",
         (unsigned long long)t.dropped);
  if (h->bytes_lost)
    warn("%llu bytes from the terminal were lost: the device's receiver "
         "was disabled",
         (unsigned long long)h->bytes_lost);
  if (st != cpu_Crashed && st != cpu_Stopped && st != cpu_Done)
    fprintf(stderr,
            PROG ": stopped at t=%.1f simulated s (%.1f s of wall "
                 "time); %llu bytes from the terminal, %llu to it\n",
            sim_time(h), h->wall_s, (unsigned long long)t.from_term,
            (unsigned long long)(h->bytes_out - t.unheard - t.dropped));
}

void term_close(void)
{
  pty_close(&t.pty);
}
