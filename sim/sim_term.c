/*
 * sim_term.c - imu-sim's terminal mode pieces (see sim_term.h).
 */
#define _GNU_SOURCE
#include "sim_term.h"
#include "sim_err.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/inotify.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

/* ---- pseudo-terminal -------------------------------------------------- */

int pty_open(pty_t *p, const char *link, char *err, size_t errlen)
{
  struct termios t;
  memset(p, 0, sizeof *p);
  p->opens = -1;
  p->master = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (p->master < 0) {
    err_set(err, errlen, "cannot create a pseudo-terminal: %s",
            strerror(errno));
    return -1;
  }
  if (grantpt(p->master) || unlockpt(p->master) ||
      ptsname_r(p->master, p->slave, sizeof p->slave)) {
    err_set(err, errlen, "cannot set up the pseudo-terminal: %s",
            strerror(errno));
    goto error;
  }
  /* Raw mode on the slave: echo there would send the device's own output
   * back into its receiver.  Opening and closing the slave once also
   * makes the master report a hangup until a terminal opens it, which is
   * how pty_state() tells whether one is there. */
  int s = open(p->slave, O_RDWR | O_NOCTTY);
  if (s < 0) {
    err_set(err, errlen, "%s: %s", p->slave, strerror(errno));
    goto error;
  }
  if (tcgetattr(s, &t) == 0) {
    cfmakeraw(&t);
    cfsetispeed(&t, B115200);
    cfsetospeed(&t, B115200);
    tcsetattr(s, TCSANOW, &t);
  }
  close(s);

  if (link) {
    struct stat st;
    char tmp[4096];
    if (lstat(link, &st) == 0 && !S_ISLNK(st.st_mode)) {
      err_set(err, errlen, "--link %s: exists and is not a symbolic link",
              link);
      close(p->master);
      p->master = -1;
      return -2;
    }
    snprintf(tmp, sizeof tmp, "%s.%ld.tmp", link, (long)getpid());
    unlink(tmp);
    if (symlink(p->slave, tmp) || rename(tmp, link)) {
      err_set(err, errlen, "--link %s: %s", link, strerror(errno));
      unlink(tmp);
      close(p->master);
      p->master = -1;
      return -2;
    }
    p->link = strdup(link);
  }
  return 0;
error:
  close(p->master);
  p->master = -1;
  return -1;
}

int pty_state(const pty_t *p, int *readable)
{
  struct pollfd q = { .fd = p->master, .events = POLLIN };
  *readable = 0;
  if (poll(&q, 1, 0) < 0)
    return 1; /* EINTR: assume nothing changed */
  if (q.revents & (POLLHUP | POLLERR | POLLNVAL))
    return 0;
  *readable = (q.revents & POLLIN) != 0;
  return 1;
}

int pty_opened(pty_t *p)
{
  if (p->opens < 0) {
    p->opens = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (p->opens < 0)
      return -1;
    if (inotify_add_watch(p->opens, p->slave, IN_OPEN) < 0) {
      close(p->opens);
      p->opens = -1;
      return -1;
    }
    return 0;
  }
  int n = 0;
  char buf[4096] __attribute__((aligned(__alignof__(struct inotify_event))));
  for (;;) {
    ssize_t len = read(p->opens, buf, sizeof buf);
    if (len <= 0)
      break;
    for (char *e = buf; e < buf + len;
         e += sizeof(struct inotify_event) + ((struct inotify_event *)e)->len)
      if (((struct inotify_event *)e)->mask & IN_OPEN)
        n++;
  }
  return n;
}

void pty_close(pty_t *p)
{
  if (p->link) {
    char target[sizeof p->slave + 1];
    ssize_t n = readlink(p->link, target, sizeof target - 1);
    if (n >= 0) {
      target[n] = 0;
      if (!strcmp(target, p->slave))
        unlink(p->link);
    }
    free(p->link);
    p->link = NULL;
  }
  if (p->master >= 0)
    close(p->master);
  p->master = -1;
  if (p->opens >= 0)
    close(p->opens);
  p->opens = -1;
}

/* ---- synthetic IMU ---------------------------------------------------- */

/* Codes of the thesis board at rest (ax ay az gx gy gz temperature) and
 * white-noise sigmas in counts close to its Allan deviations at 0.01 s. */
const double synth_offset[ROW_COLUMNS] = { 498, 494, 791, 520, 497, 498, 63 };
const double synth_sigma[ROW_COLUMNS] = { 2.0, 2.5, 1.7, 0.9, 0.67, 0.57, 0.5 };

static uint64_t splitmix64(uint64_t *s)
{
  uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/* Uniform in (0, 1). */
static double uniform(synth_t *s)
{
  return ((double)(splitmix64(&s->state) >> 11) + 0.5) *
         (1.0 / 9007199254740992.0);
}

/* Standard normal (Box-Muller, both values used). */
static double normal(synth_t *s)
{
  if (s->have_spare) {
    s->have_spare = 0;
    return s->spare;
  }
  double r = sqrt(-2.0 * log(uniform(s)));
  double a = 2.0 * M_PI * uniform(s);
  s->spare = r * sin(a);
  s->have_spare = 1;
  return r * cos(a);
}

void synth_init(synth_t *s, uint64_t seed)
{
  memset(s, 0, sizeof *s);
  s->state = seed;
}

void synth_next(synth_t *s, uint16_t code[ROW_COLUMNS])
{
  for (int i = 0; i < ROW_COLUMNS; i++) {
    double v = floor(synth_offset[i] + synth_sigma[i] * normal(s) + 0.5);
    code[i] = (uint16_t)(v < 0 ? 0 : v > ROW_CODE_MAX ? ROW_CODE_MAX : v);
  }
}
