/*
 * imu_sim.c - imu-sim: run the imu-allan firmware ELF in simavr, feed its
 * ADC the rows of a thesis data file (row i to the i-th conversion of each
 * channel), drive it through the serial protocol of docs/protocol.md and
 * capture everything it sends.  `imu-sim --help` tells the whole story;
 * harness.h lists the rooms.  This file: set-up, the run, the outcome.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "harness.h"
#include "sim_adc.h"
#include "sim_board.h"
#include "sim_cli.h"
#include "sim_drive.h"
#include "sim_fault.h"
#include "sim_measure.h"
#include "sim_msg.h"
#include "sim_serial.h"
#include "sim_termrun.h"

#include "sim_elf.h"
#include "sim_io.h"
#include "avr_eeprom.h"

/* Inputs are checked before anything is simulated. */
static void open_inputs(harness_t *h)
{
  char err[320];
  if (h->adc_path &&
      rows_open(&h->rows, h->adc_path, &h->nrows, err, sizeof err))
    die(EXIT_INPUT, "%s", err);
  if (h->pty) {
    /* rows go round and round: no end */
    h->file_rows = h->nrows;
    h->nrows = UINT64_MAX;
    if (h->synthetic)
      synth_init(&h->synth, h->seed);
  }
  if (h->uart_in_path) {
    h->nuin = uart_in_load(h->uart_in_path, &h->uin, err, sizeof err);
    if (h->nuin < 0)
      die(EXIT_INPUT, "%s", err);
  }
  if (h->board) {
    h->no_wait = 1; /* the board is powered from the start */
    return;
  }
  if (access(h->elf_path, R_OK))
    die(EXIT_INPUT, "%s: %s", h->elf_path, strerror(errno));
  if (!elf_is_avr(h->elf_path))
    die(EXIT_INPUT, "%s: not an AVR ELF file", h->elf_path);
}

/* Serial output goes to the real stdout (or -o; in terminal mode to the
 * pty, and to -o if given); simavr's own printf chatter on fd 1 goes to
 * /dev/null (stderr with -v). */
static void open_outputs(harness_t *h)
{
  if (h->pty)
    term_open(h);
  if (h->pty && !h->out_path) {
    h->out = NULL;
  } else if (h->out_path) {
    h->out = fopen(h->out_path, "wb");
    if (!h->out)
      die(EXIT_INPUT, "%s: %s", h->out_path, strerror(errno));
  } else {
    int fd = dup(STDOUT_FILENO);
    h->out = fd < 0 ? NULL : fdopen(fd, "wb");
    if (!h->out)
      die(EXIT_FAIL, "stdout: %s", strerror(errno));
  }
  if (h->out)
    setvbuf(h->out, NULL, _IOFBF, 1 << 16);
  fflush(stdout);
  int chatter = h->verbose ? dup(STDERR_FILENO) : open("/dev/null", O_WRONLY);
  if (chatter >= 0) {
    dup2(chatter, STDOUT_FILENO);
    close(chatter);
  }
}

/* The MCU with the firmware loaded and the harness's hooks in place. */
static void make_avr(harness_t *h, elf_firmware_t *fw)
{
  avr_global_logger_set(logger);
  memset(fw, 0, sizeof *fw);
  if (h->board)
    ; /* no ELF: the flash comes from the board's file (board_open) */
  else if (elf_read_firmware(h->elf_path, fw) || !fw->flashsize)
    die(EXIT_INPUT, "%s: no firmware could be loaded from this ELF",
        h->elf_path);
  if (h->mcu)
    snprintf(fw->mmcu, sizeof fw->mmcu, "%s", h->mcu);
  else if (!fw->mmcu[0])
    snprintf(fw->mmcu, sizeof fw->mmcu, "%s", "atmega168");
  if (h->freq)
    fw->frequency = h->freq;
  else if (!fw->frequency)
    fw->frequency = 10000000;
  fw->avcc = fw->aref = 1023; /* mV == code, see code_to_mv() */

  h->log_quiet = 1;
  h->avr = avr_make_mcu_by_name(fw->mmcu);
  h->log_quiet = 0;
  if (!h->avr)
    die(EXIT_INPUT, "unknown MCU '%s'", fw->mmcu);
  avr_t *avr = h->avr;
  avr_init(avr);
  if (h->board) {
    avr->frequency = fw->frequency;
    board_open(h);
  } else {
    avr_load_firmware(avr, fw);
  }
  avr->avcc = avr->aref = 1023;
  avr->log = h->verbose >= 2 ? LOG_TRACE : LOG_WARNING;
  h->timeout_cycles = (avr_cycle_count_t)(h->timeout_s * avr->frequency);

  h->adc = (avr_adc_t *)find_io(avr, "adc", 0);
  h->uart = (avr_uart_t *)find_io(avr, "uart", '0');
  if (!h->adc || !h->uart)
    die(EXIT_INPUT, "MCU '%s' has no ADC or no UART0 in simavr", fw->mmcu);
  h->adc_irq = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, 0);
  h->uart_irq = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), 0);
  adc_connect(h);
  sim_isr_watch(avr);
  serial_connect(h);
  measure_connect(h);
  fault_connect(h);
  if (!h->pty)
    drive_connect(h);
}

/* EEPROM contents at power-up (--eeprom): saved settings, blank or not. */
static void load_eeprom(harness_t *h)
{
  avr_t *avr = h->avr;
  uint8_t ee[4096];
  FILE *f = fopen(h->eeprom_path, "rb");
  if (!f)
    die(EXIT_INPUT, "--eeprom: cannot read '%s': %s", h->eeprom_path,
        strerror(errno));
  size_t n = fread(ee, 1, sizeof ee, f);
  fclose(f);
  if (n > avr->e2end + 1u)
    die(EXIT_INPUT, "--eeprom: '%s' has %zu bytes, the %s's EEPROM %u",
        h->eeprom_path, n, avr->mmcu, (unsigned)(avr->e2end + 1u));
  if (n) {
    avr_eeprom_desc_t d = { .ee = ee, .offset = 0, .size = (uint32_t)n };
    avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d);
  }
}

/* Paint SRAM for the stack high-water mark (the startup code then writes
 * .data and .bss over their part). */
static void paint_sram(harness_t *h, const elf_firmware_t *fw)
{
  avr_t *avr = h->avr;
  h->bss_end = elf_bss_end(h->elf_path);
  if (!h->bss_end)
    h->bss_end = (uint16_t)(avr->ioend + 1 + fw->datasize + fw->bsssize);
  for (unsigned a = avr->ioend + 1u; a <= avr->ramend; a++)
    avr->data[a] = PAINT;
}

/* The exit status of a run that ended in state ST, its message in
 * h->fail_msg. */
static int outcome(harness_t *h, int st)
{
  avr_t *avr = h->avr;
  if (st == cpu_Crashed || st == cpu_Stopped) {
    snprintf(h->fail_msg, sizeof h->fail_msg,
             "the firmware crashed at t=%.6f s "
             "(cycle %llu, PC 0x%04x)%s%s",
             sim_time(h), (unsigned long long)avr->cycle, (unsigned)avr->pc,
             h->last_error[0] ? ": " : "", h->last_error);
    return EXIT_FAIL;
  }
  if (st == cpu_Done) {
    /* simavr has already freed the AVR's memories here. */
    snprintf(h->fail_msg, sizeof h->fail_msg,
             "the firmware halted at t=%.6f s "
             "(cycle %llu): sleep with interrupts disabled",
             sim_time(h), (unsigned long long)avr->cycle);
    return EXIT_FAIL;
  }
  return h->fail ? h->fail : EXIT_OK;
}

int main(int argc, char **argv)
{
  static harness_t state = {
    .timeout_s = 5.0, .dev_n = -1, .dev_drops = -1, .sp_min = 0xFFFF, .seed = 1
  };
  harness_t *h = &state;
  elf_firmware_t fw;

  msg_init(h);
  parse_args(h, argc, argv);
  open_inputs(h);
  open_outputs(h);
  make_avr(h, &fw);
  if (h->eeprom_path)
    load_eeprom(h);
  if (!h->board)
    paint_sram(h, &fw); /* a board's firmware has no ELF to tell .bss */

  struct timespec t0, t1;
  clock_gettime(CLOCK_MONOTONIC, &t0);
  int st;
  if (h->pty) {
    /* The user drives the device: conversions read rows from the start. */
    h->state = ST_TERM;
    h->armed = 1;
    st = term_run(h);
    term_started(&t0); /* wall time from power-up, not from the wait */
  } else {
    st = drive_run(h);
  }
  clock_gettime(CLOCK_MONOTONIC, &t1);
  h->wall_s =
      (double)(t1.tv_sec - t0.tv_sec) + (t1.tv_nsec - t0.tv_nsec) * 1e-9;
  if (h->out)
    fflush(h->out);

  int code = outcome(h, st);
  if (h->errors && st != cpu_Crashed && st != cpu_Stopped)
    warn("simavr reported %llu error(s), the last: %s",
         (unsigned long long)h->errors, h->last_error);
  if (h->bss_end && h->sp_min < h->bss_end)
    warn("stack overflow: the stack pointer went down to 0x%04x, below the "
         "end of .bss at 0x%04x",
         (unsigned)h->sp_min, (unsigned)h->bss_end);
  if (h->pty)
    term_summary(h, st);
  else
    drive_summary(h, code);

  if (h->stats_text && st != cpu_Done)
    print_stats(h, 0);
  if (h->stats_json && st != cpu_Done)
    print_stats(h, 1);
  if (code != EXIT_OK)
    fprintf(stderr, PROG ": %s\n", h->fail_msg);
  if (h->board)
    board_close(h);
  term_close();
  if (h->out && fclose(h->out))
    die(EXIT_FAIL, "%s: %s", h->out_path ? h->out_path : "stdout",
        strerror(errno));
  rows_close(&h->rows);
  uart_in_free(h->uin, h->nuin);
  if (st != cpu_Done)
    avr_terminate(h->avr);
  return code;
}
