/*
 * harness.h - imu-sim's shared state: one harness_t, made by main
 * (imu_sim.c) and passed down to every room, none of which keeps a global
 * of it.  The rooms, each calling only those below it:
 *   imu_sim.c       main: set-up, the run, the outcome
 *   sim_cli.c       the command line (--help, options) into the state
 *   sim_termrun.c   terminal mode (--pty): the port on a pty, real-time pacing
 *   sim_drive.c     the batch run: stop, rate, reset, start, report
 *   sim_board.c     board mode (--board): flash and EEPROM kept in files, a
 *                   bootloader, the reset on opening the port
 *   sim_measure.c   cycles of marked code, stack depth, the figures (--stats)
 *   sim_serial.c    the UART, both ways: host bytes paced at the baud rate,
 *                   device bytes captured and framed into checked lines
 *   sim_adc.c       ADC conversions served from input rows
 *   sim_fault.c     the faults a real board meets, injected on request
 *   sim_msg.c       messages: warnings, fatal errors, run failures, simavr's log
 * and the helpers sim_rows.c (input files), sim_term.c (pty, synthetic IMU),
 * sim_err.c (error-buffer formatting), sim_isr.c (whole-interrupt timing).
 * A lower room reports upward only through the hooks at the end of
 * harness_t (on_line, on_byte, on_scan), which the room above sets.
 */
#ifndef HARNESS_H
#define HARNESS_H

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "sim_avr.h"
#include "avr_adc.h"
#include "avr_uart.h"

#include "sim_fault.h"
#include "sim_isr.h"
#include "sim_rows.h"
#include "sim_term.h"

#define PROG "imu-sim"
#define NEUTRAL_CODE 512
#define ROW_WIN 64       /* rows kept for channels that lag behind */
#define LINE_MAX_LEN 256 /* protocol bodies are at most 200 chars */
#define PAINT 0xA5       /* SRAM fill for the stack high-water mark */
#define LOG_CAP 20       /* simavr messages shown without -v */

enum { EXIT_OK = 0, EXIT_FAIL = 1, EXIT_INPUT = 2, EXIT_TIMEOUT = 3 };

/* Harness states: each but RUN and DONE waits for one device line.
 * TERM: terminal mode (--pty), where the user drives the device. */
enum {
  ST_BOOT,
  ST_STOP,
  ST_RATE,
  ST_RESET,
  ST_START,
  ST_RUN,
  ST_REPORT_H,
  ST_REPORT_E,
  ST_DRAIN,
  ST_DONE,
  ST_TERM
};

typedef struct {
  int level;
  avr_cycle_count_t rise;
  int seen_rise;
  uint64_t count;
  uint64_t sum, max;
} pulse_t;

typedef struct harness harness_t;

struct harness {
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
  /* board mode (sim_board.c) */
  const char *board, *bootloader, *isp_hex;
  volatile int reset_seen; /* the MCU was reset since the last look */

  avr_t *avr;
  avr_adc_t *adc;
  avr_uart_t *uart;
  avr_irq_t *adc_irq, *uart_irq;

  /* protocol state */
  int state;
  avr_cycle_count_t deadline, timeout_cycles;
  int fail; /* exit code of a failure found in a callback */
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
  uint16_t sp_min;    /* lowest stack pointer seen */
  uint32_t sp_min_pc; /* program counter (bytes) when it was seen */
  double wall_s;

  /* faults injected (sim_fault.c), and the batch run's restarts after a
   * reset: the final run covers rows first_row .. nrows - 1 */
  fault_t fault;
  uint64_t first_row, restarts;
  int report_retries; /* 'report' sent again after an error:5 */

  /* simavr log */
  char last_error[200];
  int log_shown;
  int log_quiet;
  uint64_t errors;

  /* Calls up, set by whoever runs the device (the driver, the terminal):
   * lower rooms report through them and never name the rooms above. */
  void (*on_line)(harness_t *h, char *body, size_t len, int crc_ok);
  void (*on_byte)(harness_t *h, uint8_t c); /* every device byte */
  void (*on_scan)(harness_t *h);            /* mux 6 of a row converted */
};

/* A peripheral of avr by kind ("adc", "uart", "timer") and name (0: any). */
static inline avr_io_t *find_io(avr_t *avr, const char *kind, char name)
{
  for (avr_io_t *io = avr->io_port; io; io = io->next)
    if (io->kind && !strcmp(io->kind, kind) &&
        (!name || ((avr_uart_t *)io)->name == name))
      return io;
  return NULL;
}

/* The lowest stack pointer, checked after every instruction (inline: it
 * runs once per simulated instruction). */
static inline void watch_sp(harness_t *h)
{
  avr_t *avr = h->avr;
  uint16_t sp = (uint16_t)(avr->data[R_SPL] | avr->data[R_SPH] << 8);
  if (sp < h->sp_min) {
    h->sp_min = sp;
    h->sp_min_pc = avr->pc;
  }
  sim_isr_step();
}

#endif /* HARNESS_H */
