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
}

void term_started(struct timespec *t0)
{
  *t0 = t.t0;
}

void term_summary(int st)
{
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
