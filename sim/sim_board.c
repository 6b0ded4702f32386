/*
 * sim_board.c - board mode (--board): the simulated board as it leaves the
 * factory with a serial bootloader, for `make sim-board` and `make flash`.
 *
 * - Flash: the chip's whole flash in PREFIX.flash (raw bytes), created
 *   blank (0xFF) when missing and written back whenever the firmware
 *   changes it (the bootloader's SPM page writes), so it persists between
 *   runs as a real chip's does.  --bootloader HEX is placed where its
 *   addresses say (the boot section); the reset vector then points at its
 *   first byte, as the fuses BOOTRST = 0 and BOOTSZ = its size make the
 *   chip do.  --flash HEX writes an application first, as an ISP
 *   programmer would.
 * - EEPROM: PREFIX.eeprom, the same way.
 * - Resets: power-on at start (simavr sets PORF); opening the port resets
 *   the MCU through its RESET pin (EXTRF), as the DTR auto-reset capacitor
 *   of an Arduino-style board does; the watchdog's own resets are simavr's.
 *   Each reset leaves SRAM as it was, as on the chip.
 * - SPM works only from the boot loader section, as on the chip.
 * - SIGUSR1 hangs the firmware as a stuck main loop would (for the
 *   watchdog tests): outside interrupts, it jumps to the first `rjmp .` of
 *   the application, interrupts left on.
 */
#include "sim_board.h"

#include <errno.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>

#include "sim_hex.h"
#include "sim_io.h"
#include "sim_regbit.h"
#include "avr_eeprom.h"
#include "avr_flash.h"

#include "sim_msg.h"

static struct {
  char flash_path[4096], eeprom_path[4096];
  uint8_t *flash_saved; /* what the flash file holds */
  uint8_t eeprom_saved[4096];
  uint32_t boot_start; /* byte address; 0: no bootloader */
  uint32_t flash_writes, eeprom_writes, spm_dropped;
  void (*mcu_reset)(avr_t *avr); /* the core's own reset hook */
  int resets;
  harness_t *h; /* for the reset hook, which has no pointer */
} b;

static volatile sig_atomic_t hang_request;

/* The chip carries out SPM only from its boot loader section; simavr from
 * anywhere, so a firmware gone astray (half written, say) could rewrite the
 * bootloader.  This module sees the SPM ioctl before simavr's flash module
 * (simavr asks its modules newest first) and drops an SPM from elsewhere. */
static int spm_guard_ioctl(avr_io_t *io, uint32_t ctl, void *param)
{
  (void)param;
  if (ctl != AVR_IOCTL_FLASH_SPM)
    return -1;
  uint32_t flash_len = io->avr->flashend + 1u;
  uint32_t bls_start = b.boot_start ? b.boot_start : flash_len - flash_len / 8u;
  if (io->avr->pc >= bls_start)
    return -1; /* the flash module's */
  b.spm_dropped++;
  return 0;
}

static avr_io_t spm_guard = { .kind = "spm-guard", .ioctl = spm_guard_ioctl };

static void on_hang_signal(int sig)
{
  (void)sig;
  hang_request = 1;
}

/* Reads PATH (up to LEN bytes) into BUF; 1 if it existed. */
static int load_file(const avr_t *avr, const char *path, uint8_t *buf,
                     size_t len, const char *what)
{
  FILE *f = fopen(path, "rb");
  if (!f) {
    if (errno != ENOENT)
      die(EXIT_INPUT, "%s: %s", path, strerror(errno));
    return 0;
  }
  size_t n = fread(buf, 1, len, f);
  int extra = fgetc(f) != EOF;
  fclose(f);
  if (n != len || extra)
    die(EXIT_INPUT,
        "%s: %zu bytes, not the %zu of the %s's %s (delete it "
        "for a blank chip)",
        path, n + (size_t)extra, len, avr->mmcu, what);
  return 1;
}

/* Write-then-rename, so a killed simulator never leaves half a file. */
static void save_file(const char *path, const uint8_t *buf, size_t len)
{
  char tmp[4200];
  snprintf(tmp, sizeof tmp, "%s.tmp", path);
  FILE *f = fopen(tmp, "wb");
  if (!f || fwrite(buf, 1, len, f) != len || fclose(f) || rename(tmp, path))
    warn("%s: cannot save: %s", path, strerror(errno));
}

/* Writes a hex file into flash; returns its lowest address. */
static uint32_t put_hex(avr_t *avr, const char *path, const char *what)
{
  ihex_chunk_p chunks = NULL;
  int n = read_ihex_chunks(path, &chunks);
  uint32_t low = UINT32_MAX;
  if (n <= 0)
    die(EXIT_INPUT, "%s %s: not an Intel hex file", what, path);
  for (int i = 0; i < n; i++) {
    if (chunks[i].baseaddr + chunks[i].size > avr->flashend + 1u)
      die(EXIT_INPUT, "%s %s: bytes at 0x%x-0x%x, beyond the %s's flash", what,
          path, (unsigned)chunks[i].baseaddr,
          (unsigned)(chunks[i].baseaddr + chunks[i].size - 1), avr->mmcu);
    memcpy(avr->flash + chunks[i].baseaddr, chunks[i].data, chunks[i].size);
    if (chunks[i].baseaddr < low)
      low = chunks[i].baseaddr;
  }
  free_ihex_chunks(chunks);
  return low;
}

/* Every reset, whoever causes it: simavr has stopped the cycle timers and
 * will set the cycle count to 0; the harness re-arms its own. */
static void board_reset_hook(avr_t *avr)
{
  if (b.mcu_reset)
    b.mcu_reset(avr);
  b.resets++;
  b.h->reset_seen = 1;
}

void board_open(harness_t *h)
{
  b.h = h;
  avr_t *avr = h->avr;
  size_t flash_len = avr->flashend + 1u, ee_len = avr->e2end + 1u;

  snprintf(b.flash_path, sizeof b.flash_path, "%s.flash", h->board);
  snprintf(b.eeprom_path, sizeof b.eeprom_path, "%s.eeprom", h->board);
  b.flash_saved = malloc(flash_len);
  if (!b.flash_saved || ee_len > sizeof b.eeprom_saved)
    die(EXIT_FAIL, "out of memory");

  memset(avr->flash, 0xFF, flash_len);
  load_file(avr, b.flash_path, avr->flash, flash_len, "flash");
  if (h->isp_hex) {
    /* chip erase of the application section, then the hex */
    memset(avr->flash, 0xFF, b.boot_start ? b.boot_start : flash_len);
    put_hex(avr, h->isp_hex, "--flash");
  }
  if (h->bootloader && strcmp(h->bootloader, "none")) {
    b.boot_start = put_hex(avr, h->bootloader, "--bootloader");
    if (b.boot_start < flash_len / 2)
      die(EXIT_INPUT, "--bootloader %s starts at 0x%x: not a boot section",
          h->bootloader, (unsigned)b.boot_start);
  }
  avr->codeend = avr->flashend;
  memcpy(b.flash_saved, avr->flash, flash_len);
  save_file(b.flash_path, avr->flash, flash_len);

  memset(b.eeprom_saved, 0xFF, ee_len);
  load_file(avr, b.eeprom_path, b.eeprom_saved, ee_len, "EEPROM");
  avr_eeprom_desc_t d = { .ee = b.eeprom_saved,
                          .offset = 0,
                          .size = (uint32_t)ee_len };
  avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d);

  /* BOOTRST: the reset vector is the boot section's start */
  avr->reset_pc = b.boot_start;
  avr->pc = b.boot_start;
  b.mcu_reset = avr->reset;
  avr->reset = board_reset_hook;
  avr_register_io(avr, &spm_guard);

  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_hang_signal;
  sa.sa_flags = SA_RESTART;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGUSR1, &sa, NULL);
}

/* The RESET pin pulled low and released (the DTR capacitor's pulse). */
void board_external_reset(harness_t *h)
{
  avr_t *avr = h->avr;
  avr_reset(avr);
  avr_regbit_set(avr, avr->reset_flags.extrf);
  if (h->verbose)
    fprintf(stderr, PROG ": external reset (the port was opened)\n");
}

/* Flash and EEPROM to their files when they changed; the hang request. */
void board_poll(harness_t *h)
{
  avr_t *avr = h->avr;
  size_t flash_len = avr->flashend + 1u, ee_len = avr->e2end + 1u;
  if (memcmp(b.flash_saved, avr->flash, flash_len)) {
    memcpy(b.flash_saved, avr->flash, flash_len);
    save_file(b.flash_path, avr->flash, flash_len);
    b.flash_writes++;
  }
  uint8_t ee[4096];
  avr_eeprom_desc_t d = { .ee = ee, .offset = 0, .size = (uint32_t)ee_len };
  avr_ioctl(avr, AVR_IOCTL_EEPROM_GET, &d);
  if (memcmp(b.eeprom_saved, d.ee, ee_len)) {
    memcpy(b.eeprom_saved, d.ee, ee_len);
    save_file(b.eeprom_path, b.eeprom_saved, ee_len);
    b.eeprom_writes++;
  }
  /* A loop that hangs with interrupts on (not inside an interrupt, which
   * would leave them off and the watchdog's warning unanswerable). */
  if (hang_request && avr->sreg[S_I]) {
    hang_request = 0;
    uint32_t end = b.boot_start ? b.boot_start : flash_len;
    for (uint32_t a = 0; a + 1 < end; a += 2)
      if (avr->flash[a] == 0xFF && avr->flash[a + 1] == 0xCF) { /* rjmp . */
        avr->pc = a;
        if (h->verbose)
          fprintf(stderr, PROG ": hung at 0x%04x (SIGUSR1)\n", (unsigned)a);
        return;
      }
    warn("SIGUSR1: no 'rjmp .' in the application to hang in");
  }
}

void board_close(harness_t *h)
{
  if (!b.flash_saved)
    return;
  board_poll(h);
  if (b.spm_dropped)
    warn("%u SPM instructions outside the boot loader section were ignored, "
         "as the chip ignores them",
         (unsigned)b.spm_dropped);
  if (h->verbose)
    fprintf(stderr, PROG ": %d resets, flash saved %u times, EEPROM %u times\n",
            b.resets, (unsigned)b.flash_writes, (unsigned)b.eeprom_writes);
  free(b.flash_saved);
  b.flash_saved = NULL;
}
