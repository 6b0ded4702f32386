/*
 * sim_term.h - imu-sim's terminal mode (--pty) pieces: the pseudo-terminal
 * that stands for the device's serial port, its symlink, and the built-in
 * synthetic IMU (--synthetic).
 */
#ifndef SIM_TERM_H
#define SIM_TERM_H

#include <stddef.h>
#include <stdint.h>

#include "sim_rows.h"

typedef struct {
  int master;      /* non-blocking; the device's side */
  int opens;       /* inotify on the slave (pty_opened), or -1 */
  char slave[128]; /* what a terminal opens, e.g. /dev/pts/7 */
  char *link;      /* symlink to slave we made, or NULL */
} pty_t;

/* Create a pseudo-terminal in raw mode (no echo, no line editing, no
 * CR/LF translation), and with LINK a symlink LINK -> slave (an existing
 * symlink at LINK is replaced; anything else there is an error).  0, or
 * -1 (the pty) or -2 (the link) with one line in err. */
int pty_open(pty_t *p, const char *link, char *err, size_t errlen);

/* Poll the master without waiting: 1 if a terminal has the slave open,
 * 0 if none; *readable set when bytes from the terminal wait. */
int pty_state(const pty_t *p, int *readable);

/* How many times a terminal opened the slave since the last call (the
 * first call starts counting; -1 if the system cannot tell).  Unlike
 * pty_state() it misses no close-and-open between two looks. */
int pty_opened(pty_t *p);

/* Close the master and remove the symlink if it still points to our slave. */
void pty_close(pty_t *p);

/* The built-in synthetic IMU: seeded white Gaussian noise around
 * thesis-like offsets, rounded to codes. */
typedef struct {
  uint64_t state;
  int have_spare;
  double spare;
} synth_t;

extern const double synth_offset[ROW_COLUMNS];
extern const double synth_sigma[ROW_COLUMNS];

void synth_init(synth_t *s, uint64_t seed);
void synth_next(synth_t *s, uint16_t code[ROW_COLUMNS]);

#endif /* SIM_TERM_H */
