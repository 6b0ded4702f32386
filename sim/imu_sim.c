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

#include "sim_elf.h"
#include "sim_io.h"
#include "avr_eeprom.h"

harness_t g = { .timeout_s = 5.0, .dev_n = -1, .dev_drops = -1, .sp_min = 0xFFFF,
                .seed = 1 };

/* Inputs are checked before anything is simulated. */
static void open_inputs(void)
{
  char err[320];
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
  if (g.board) {
    g.no_wait = 1;    /* the board is powered from the start */
    return;
  }
  if (access(g.elf_path, R_OK))
    die(EXIT_INPUT, "%s: %s", g.elf_path, strerror(errno));
  if (!elf_is_avr(g.elf_path))
    die(EXIT_INPUT, "%s: not an AVR ELF file", g.elf_path);
}

/* Serial output goes to the real stdout (or -o; in terminal mode to the
 * pty, and to -o if given); simavr's own printf chatter on fd 1 goes to
 * /dev/null (stderr with -v). */
static void open_outputs(void)
{
  if (g.pty)
    term_open();
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
}

avr_io_t *find_io(const char *kind, char name)
{
  for (avr_io_t *io = g.avr->io_port; io; io = io->next)
    if (io->kind && !strcmp(io->kind, kind) &&
        (!name || ((avr_uart_t *)io)->name == name))
      return io;
  return NULL;
}

/* The MCU with the firmware loaded and the harness's hooks in place. */
static void make_avr(elf_firmware_t *fw)
{
  avr_global_logger_set(logger);
  memset(fw, 0, sizeof *fw);
  if (g.board)
    ;   /* no ELF: the flash comes from the board's file (board_open) */
  else if (elf_read_firmware(g.elf_path, fw) || !fw->flashsize)
    die(EXIT_INPUT, "%s: no firmware could be loaded from this ELF", g.elf_path);
  if (g.mcu)
    snprintf(fw->mmcu, sizeof fw->mmcu, "%s", g.mcu);
  else if (!fw->mmcu[0])
    snprintf(fw->mmcu, sizeof fw->mmcu, "%s", "atmega168");
  if (g.freq)
    fw->frequency = g.freq;
  else if (!fw->frequency)
    fw->frequency = 10000000;
  fw->avcc = fw->aref = 1023;   /* mV == code, see code_to_mv() */

  g.log_quiet = 1;
  g.avr = avr_make_mcu_by_name(fw->mmcu);
  g.log_quiet = 0;
  if (!g.avr)
    die(EXIT_INPUT, "unknown MCU '%s'", fw->mmcu);
  avr_t *avr = g.avr;
  avr_init(avr);
  if (g.board) {
    avr->frequency = fw->frequency;
    board_open();
  } else {
    avr_load_firmware(avr, fw);
  }
  avr->avcc = avr->aref = 1023;
  avr->log = g.verbose >= 2 ? LOG_TRACE : LOG_WARNING;
  g.timeout_cycles = (avr_cycle_count_t)(g.timeout_s * avr->frequency);
  set_state(ST_BOOT);

  g.adc = (avr_adc_t *)find_io("adc", 0);
  g.uart = (avr_uart_t *)find_io("uart", '0');
  if (!g.adc || !g.uart)
    die(EXIT_INPUT, "MCU '%s' has no ADC or no UART0 in simavr", fw->mmcu);
  g.adc_irq = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, 0);
  g.uart_irq = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), 0);
  adc_connect();
  sim_isr_watch(avr);
  serial_connect();
  measure_connect();
}

/* EEPROM contents at power-up (--eeprom): saved settings, blank or not. */
static void load_eeprom(void)
{
  avr_t *avr = g.avr;
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

/* Paint SRAM for the stack high-water mark (the startup code then writes
 * .data and .bss over their part). */
static void paint_sram(const elf_firmware_t *fw)
{
  avr_t *avr = g.avr;
  g.bss_end = elf_bss_end(g.elf_path);
  if (!g.bss_end)
    g.bss_end = (uint16_t)(avr->ioend + 1 + fw->datasize + fw->bsssize);
  for (unsigned a = avr->ioend + 1u; a <= avr->ramend; a++)
    avr->data[a] = PAINT;
}

/* The exit status of a run that ended in state ST, its message in
 * g.fail_msg. */
static int outcome(int st)
{
  avr_t *avr = g.avr;
  if (st == cpu_Crashed || st == cpu_Stopped) {
    snprintf(g.fail_msg, sizeof g.fail_msg, "the firmware crashed at t=%.6f s "
             "(cycle %llu, PC 0x%04x)%s%s", sim_time(),
             (unsigned long long)avr->cycle, (unsigned)avr->pc,
             g.last_error[0] ? ": " : "", g.last_error);
    return EXIT_FAIL;
  }
  if (st == cpu_Done) {
    /* simavr has already freed the AVR's memories here. */
    snprintf(g.fail_msg, sizeof g.fail_msg, "the firmware halted at t=%.6f s "
             "(cycle %llu): sleep with interrupts disabled", sim_time(),
             (unsigned long long)avr->cycle);
    return EXIT_FAIL;
  }
  return g.fail ? g.fail : EXIT_OK;
}

int main(int argc, char **argv)
{
  elf_firmware_t fw;

  parse_args(argc, argv);
  open_inputs();
  open_outputs();
  make_avr(&fw);
  if (g.eeprom_path)
    load_eeprom();
  if (!g.board)
    paint_sram(&fw);    /* a board's firmware has no ELF to tell .bss */

  struct timespec t0, t1;
  clock_gettime(CLOCK_MONOTONIC, &t0);
  int st;
  if (g.pty) {
    /* The user drives the device: conversions read rows from the start. */
    g.state = ST_TERM;
    g.armed = 1;
    st = term_run();
    term_started(&t0);    /* wall time from power-up, not from the wait */
  } else {
    st = drive_run();
  }
  clock_gettime(CLOCK_MONOTONIC, &t1);
  g.wall_s = (double)(t1.tv_sec - t0.tv_sec) + (t1.tv_nsec - t0.tv_nsec) * 1e-9;
  if (g.out)
    fflush(g.out);

  int code = outcome(st);
  if (g.errors && st != cpu_Crashed && st != cpu_Stopped)
    warn("simavr reported %llu error(s), the last: %s",
         (unsigned long long)g.errors, g.last_error);
  if (g.bss_end && g.sp_min < g.bss_end)
    warn("stack overflow: the stack pointer went down to 0x%04x, below the "
         "end of .bss at 0x%04x", (unsigned)g.sp_min, (unsigned)g.bss_end);
  if (g.pty)
    term_summary(st);
  else
    drive_summary(code);

  if (g.stats_text && st != cpu_Done)
    print_stats(0);
  if (g.stats_json && st != cpu_Done)
    print_stats(1);
  if (code != EXIT_OK)
    fprintf(stderr, PROG ": %s\n", g.fail_msg);
  if (g.board)
    board_close();
  term_close();
  if (g.out && fclose(g.out))
    die(EXIT_FAIL, "%s: %s", g.out_path ? g.out_path : "stdout", strerror(errno));
  rows_close(&g.rows);
  uart_in_free(g.uin, g.nuin);
  if (st != cpu_Done)
    avr_terminate(g.avr);
  return code;
}
