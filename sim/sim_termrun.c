/*
 * sim_termrun.c - terminal mode (--pty): the device's serial port on a
 * pseudo-terminal for a person or a program, simulated time paced to the
 * wall clock (or --fast), device output lost while no terminal listens.
 */
#define _GNU_SOURCE
#include "harness.h"
#include "sim_regbit.h"

#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

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
  uint64_t flushed;           /* host bytes lost to a closed line or a reset */
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
/* Bytes from a terminal that closed, or sent to an MCU that was reset
 * meanwhile, never arrive (its UART restarts empty): a next session must
 * not receive the end of the last one (say, half a page of an upload that
 * was cut off, which would throw the bootloader out of step). */
static void drop_host_bytes(void)
{
  uint8_t buf[256];
  t.flushed += g.txq_len;
  g.txq_len = 0;
  g.txq_head = 0;
  g.user_line_len = 0;
  for (;;) {      /* what the closed terminal left in the pty */
    ssize_t n = read(t.pty.master, buf, sizeof buf);
    if (n <= 0 && !(n < 0 && errno == EINTR))
      break;
    if (n > 0)
      t.flushed += (uint64_t)n;
  }
}

static void term_poll(void)
{
  int readable;
  int now = pty_state(&t.pty, &readable);
  int opened = g.board ? pty_opened(&t.pty) : 0;
  if (now != t.connected || opened > 0) {
    if (g.verbose)
      fprintf(stderr, PROG ": t=%.3f s: terminal %s\n", sim_time(),
              now ? "opened" : "closed");
    if (!now || opened > 0)
      drop_host_bytes();          /* they went with the last line */
    /* DTR auto-reset: every open, even a close and open between two
     * looks (inotify counts them); without inotify, a change seen */
    if (g.board && (opened > 0 || (opened < 0 && now && !t.connected))) {
      board_external_reset();
      now = pty_state(&t.pty, &readable);
    }
    t.connected = now;
  }
  /* Typed bytes wait in the pty until the firmware has enabled its
   * receiver: the device powers up when the terminal opens it (as a board
   * reset by DTR does), and a command sent at once would otherwise reach
   * a UART not yet listening and be lost without a reply. */
  if (!avr_regbit_get(g.avr, g.uart->rxen))
    return;
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
  if (g.out && t.olen)
    fflush(g.out);    /* -o: a copy others may read while the device runs */
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

void term_out(uint8_t c)
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
/* After any reset simavr has dropped the cycle timers (and newer simavr
 * versions restart the cycle count from 0; 1.6 goes on counting): the
 * harness re-arms its timers, and re-bases the real-time comparison if
 * the count went back. */
static void term_after_reset(void)
{
  avr_t *avr = g.avr;
  g.reset_seen = 0;
  g.tx_busy = 0;
  g.tx_free_at = 0;
  g.xoff = 0;
  t.flushed += g.txq_len;     /* bytes on the wire during the reset */
  g.txq_len = 0;
  g.txq_head = 0;
  g.user_line_len = 0;
  if (avr->cycle < t.c0) {
    clock_gettime(CLOCK_MONOTONIC, &t.t0);
    t.c0 = avr->cycle;
  }
  t.next_io = avr->cycle + t.slice;
  if (!g.fast)
    avr_cycle_timer_register(avr, t.slice, term_tick, NULL);
  tx_kick();
}

/* Board mode: a chip does not stop on an opcode simavr cannot run (a
 * half-written firmware, say); it goes astray until it is reset.  The board
 * waits for a reset (the port opened) and runs on. */
static int term_stuck(void)
{
  avr_t *avr = g.avr;
  warn("t=%.3f s: the firmware crashed (PC 0x%04x)%s%s; the board is stuck "
       "until it is reset (open the port)", sim_time(), (unsigned)avr->pc,
       g.last_error[0] ? ": " : "", g.last_error);
  while (!stop_signal && avr->state != cpu_Running) {
    sleep_s(0.001);
    term_flush();
    term_poll();
    board_poll();
  }
  if (g.reset_seen)
    term_after_reset();
  return avr->state;
}

int term_run(void)
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
  g.reset_seen = 0;
  term_poll();
  if (g.reset_seen)
    term_after_reset();
  unsigned slices = 0;
  while (!stop_signal && !g.fail) {
    st = avr_run(avr);
    if (g.board && (st == cpu_Crashed || st == cpu_Stopped))
      st = term_stuck();
    if (st == cpu_Crashed || st == cpu_Done || st == cpu_Stopped)
      break;
    watch_sp();
    if (g.reset_seen)
      term_after_reset();
    if (avr->cycle < t.next_io)
      continue;
    t.next_io = avr->cycle + t.slice;
    term_flush();
    term_poll();
    if (g.reset_seen)
      term_after_reset();
    if (g.board && ++slices % 50 == 0)
      board_poll();           /* every 50 ms (250 ms with --fast) */
    if (!g.fast)
      term_pace();
  }
  if (st != cpu_Done)
    term_flush();
  return st;
}

void term_open(void)
{
  char err[320];
  int fd = dup(STDOUT_FILENO);
  t.info = fd < 0 ? NULL : fdopen(fd, "w");
  if (!t.info)
    die(EXIT_FAIL, "stdout: %s", strerror(errno));
  int r = pty_open(&t.pty, g.link_path, err, sizeof err);
  if (r)
    die(r == -2 ? EXIT_INPUT : EXIT_FAIL, "%s", err);
  atexit(term_cleanup);     /* the link goes, however imu-sim ends */
  if (g.board && pty_opened(&t.pty) < 0)     /* start counting opens */
    warn("no inotify on %s: a close and open faster than a millisecond "
         "may not reset the board", t.pty.slave);
}

void term_started(struct timespec *t0)
{
  *t0 = t.t0;
}

void term_summary(int st)
{
  if (g.verbose && t.flushed)
    fprintf(stderr, PROG ": %llu bytes from the terminal were lost to a reset "
            "or a closed line\n", (unsigned long long)t.flushed);
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
}

void term_close(void)
{
  pty_close(&t.pty);
}
