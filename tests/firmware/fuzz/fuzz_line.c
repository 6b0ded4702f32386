/*
 * fuzz_line - the device's line discipline end to end: the whole firmware
 * natively (the real console: receiver, line editor, echo, timeout; the
 * control room, scheduler, producers, settings and engine), with the fakes
 * of tests/firmware/native (UART at 115200 baud through the device's 8-byte ring,
 * ADC, EEPROM, clock), fed arbitrary byte streams interleaved with mode and
 * echo changes, pauses, Ctrl-C/Esc, UART overruns (bytes lost, the next
 * one flagged, as the AVR's DOR flags it) and framing errors (bytes
 * flagged with FE, which the device throws away).
 *
 * What the device is about to run is what it hands command_parse(): the
 * link-time --wrap of that function records every text.  Checked against
 * the stream as sent (docs/protocol.md, "Commands"):
 *   - every text parsed is a clean line of the stream, and they come in
 *     the stream's order, none twice: a line is the bytes after a CR, LF,
 *     Ctrl-C or Esc up to the next CR or LF, after BS/DEL editing; it is
 *     clean when none of its bytes (its end included) was lost in an
 *     overrun or to a framing error, nor the bytes right before its first, it holds only
 *     printable ASCII and TAB, and it never grew past COMMAND_LINE_MAX;
 *     a `*` starts the line's check, right only as 4 upper-case hex
 *     digits, the CRC of the text before it (what runs);
 *     a silence past CONSOLE_TIMEOUT_MS ends an open line (refused) and
 *     what follows starts a new one.  So a line that lost bytes, one with
 *     a bad byte or one cut by Ctrl-C/Esc is never run, nor glued to
 *     another;
 *   - when the device's own RX ring never overflowed (the only loss the
 *     model does not make itself) and no two gaps waited unread at once
 *     (then every byte up to the later one counts as following a gap, and
 *     a clean line between them may be refused: docs/protocol.md), every
 *     clean line ran, in order: none refused or dropped without a reason;
 *   - Ctrl-C before a command works in every mode: after the stream and a
 *     quiet moment (PROBE_QUIET_MS), Ctrl-C and a clean `status` line back
 *     to back: whatever mode the stream left the device in, the line runs;
 *   - the device is never left deaf: if it did not, the same with Esc and
 *     a quiet moment after it too, up to PROBE_TRIES times a second apart,
 *     tells a false refusal from a device that no longer listens.
 *
 * The firmware's globals are put back to their power-up image before each
 * input (they live in sections of their own: fuzz_line_state.h), so that
 * an input gives the same run alone or after any other.
 *
 * Input: bytes to send, except 0xFF, which starts an operation o (the next
 * byte), its argument a = o >> 3:
 *   o & 7 = 0  send command number a of COMMANDS (mode, echo, rate, ...) and CR
 *           1  pause (a + 1) * 8 ms, the device running
 *           2  an overrun: the next a % 8 + 1 bytes are lost on the way in
 *           3  send the byte 0xFF itself
 *           4  pause past the line's timeout (CONSOLE_TIMEOUT_MS + 0.3 s)
 *           5  framing errors: the next a % 8 + 1 bytes arrive with FE set
 *           else pause a ms.
 * Silences are kept 100 ms clear of the line's timeout either way, where
 * the device's 26 ms clock could go either way.  The pauses of an input
 * add up to PAUSE_MAX_MS at most: device time is what an input costs (a
 * second of streaming at 1500 Hz is ~10^4 loop passes).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* The fakes, their state with the firmware's (reset before every input). */
#include "../native/fake_device.c"

#pragma clang section bss = "" data = ""

#include "command.h"
#include "config.h"
#include "console.h"
#include "fuzz_util.h"
#include "settings.h"
#include "stream.h"
#include "switchboard.h"
#include "../native/ref_crc16.h"

/* An unusual spelling of a harmless command (the parser ignores case and
 * trailing blanks), so that the stream itself hardly ever sends it. */
#define PROBE "Status\t"
#define PROBE_QUIET_MS 100u
#define PROBE_TRIES 3
#define MAX_LINES 4096

static const char *const COMMANDS[] = {
    "mode allan", "mode raw", "mode binary", "mode both",    "echo on",    "echo off", "rate 1500",
    "rate 100",   "rate 50",  "interval 1",  "interval 0",   "stop",       "start",    "start 20",
    "report",     "status",   "help",        "units counts", "units phys", "reset",    "range 6",
};
#define NCOMMANDS (sizeof COMMANDS / sizeof COMMANDS[0])

/* ---- what the device parsed ---- */
static char parsed[MAX_LINES][COMMAND_LINE_MAX + 1];
static size_t nparsed;
static int parse_overflow;

uint8_t __real_command_parse(const char *line, command_t *out);
uint8_t __wrap_command_parse(const char *line, command_t *out)
{
  size_t n = strlen(line);
  FUZZ_CHECK(n <= COMMAND_LINE_MAX, "a line of %zu characters was parsed: \"%s\"", n, line);
  if (nparsed < MAX_LINES)
    memcpy(parsed[nparsed++], line, n + 1);
  else
    parse_overflow = 1;
  return __real_command_parse(line, out);
}

/* ---- the stream as sent, and the model's clean lines ---- */
static uint8_t sent[1 << 16];
static uint8_t lost[1 << 16];     /* this byte never reached the device: 1 an overrun, 2 FE */
static uint64_t arrival[1 << 16]; /* when its last bit was on the wire (ns) */
static size_t nsent;

typedef struct {
  char text[COMMAND_LINE_MAX + 1];
  size_t end; /* index of its CR or LF in sent[] */
} line_t;
static line_t model[MAX_LINES];
static size_t nmodel;

/* A line may end in a check, `*` and the text's CRC in 4 upper-case hex
 * digits: it runs (the text before `*`) only when the check is exactly
 * that; every byte after `*` but the line's end, Ctrl-C and Esc is a
 * digit of the check. */
static size_t build_model(void)
{
  char text[COMMAND_LINE_MAX + 1], check[5];
  size_t len = 0, count = 0, i, ndig = 0;
  int dirty = 0, star = 0;
  for (i = 0; i < nsent; i++) {
    uint8_t c = sent[i];
    /* an open line times out in a silence past CONSOLE_TIMEOUT_MS (none is
     * near it: flush()): what comes after starts a new line */
    if (i && arrival[i] - arrival[i - 1] > CONSOLE_TIMEOUT_MS * 1000000ull) {
      len = 0;
      dirty = star = 0;
    }
    /* a loss at a byte spoils the line that byte is in, and an overrun's
     * the line of the byte after it too (DOR comes with that byte, even
     * after a timeout; a framing error's gap is seen at once) */
    if (lost[i] || (i && lost[i - 1] == 1))
      dirty = 1;
    if (lost[i])
      continue;
    if (c == '\r' || c == '\n') {
      char want[8];
      snprintf(want, sizeof want, "%04X", ref_crc16(text, len));
      if (star && (ndig != 4 || memcmp(check, want, 4) != 0))
        dirty = 1;
      if (!dirty && len && count < MAX_LINES) {
        memcpy(model[count].text, text, len);
        model[count].text[len] = 0;
        model[count].end = i;
        count++;
      }
      len = 0;
      dirty = star = 0;
    } else if (c == 0x03 || c == 0x1B) {
      len = 0;
      dirty = star = 0;
    } else if (star) {
      if (ndig < 4)
        check[ndig] = (char)c;
      ndig++;
    } else if (c == '*') {
      star = 1;
      ndig = 0;
    } else if (c == 0x08 || c == 0x7F) {
      if (len)
        len--;
    } else if ((c < 0x20 && c != '\t') || c > 0x7E || len >= COMMAND_LINE_MAX) {
      dirty = 1;
    } else {
      text[len++] = (char)c;
    }
  }
  return count;
}

/* ---- the firmware's power-up image ---- */
extern char __start_fwstate_bss[], __stop_fwstate_bss[];
extern char __start_fwstate_data[], __stop_fwstate_data[];
static char *image_bss, *image_data;

/* A plain word copy: ASan's memcpy would object to the globals' redzones,
 * which lie inside the sections too. */
__attribute__((no_sanitize("address", "coverage"))) static void copy_words(char *dst, const char *src,
                                                                           size_t n)
{
  volatile uint64_t *d = (volatile uint64_t *)dst;
  const volatile uint64_t *s = (const volatile uint64_t *)src;
  for (size_t i = 0; i < n / 8; i++)
    d[i] = s[i];
  for (size_t i = n & ~(size_t)7; i < n; i++)
    ((volatile char *)dst)[i] = src[i];
}

static void image_save(void)
{
  size_t nb = (size_t)(__stop_fwstate_bss - __start_fwstate_bss);
  size_t nd = (size_t)(__stop_fwstate_data - __start_fwstate_data);
  image_bss = malloc(nb + 8);
  image_data = malloc(nd + 8);
  copy_words(image_bss, __start_fwstate_bss, nb);
  copy_words(image_data, __start_fwstate_data, nd);
}

static void image_restore(void)
{
  free(rx_queue); /* the fake's send queue: heap blocks of the last input */
  free(rx_lostq);
  copy_words(__start_fwstate_bss, image_bss, (size_t)(__stop_fwstate_bss - __start_fwstate_bss));
  copy_words(__start_fwstate_data, image_data, (size_t)(__stop_fwstate_data - __start_fwstate_data));
}

/* ---- driving the device ---- */
/* fx_run_us() with the waits skipped: after a few loop passes in which
 * nothing moved (nothing written, read, sampled or taken) and the device
 * would sleep (loop_has_work()), the loop would only spin until the next
 * event, so the clock jumps there: a byte leaving the TX ring, one
 * arriving, an ADC tick.  The loop runs a pass at every event, as before.
 * (Skipping while the device had work once froze a report's settling for
 * a whole pause: a timed-out line's reply then came after the next
 * command was sent, and the ring overflowed with it.) */
static int ring_full;   /* the RX ring overflowed during this input */
static int gaps_merged; /* two gaps waited unread at once (the fake's rx_gap_more) */

static void run_us(uint64_t us)
{
  uint64_t end = now_ns + us * 1000u;
  int still = 0;
  while (now_ns < end) {
    uint64_t next = now_ns + 20000u;
    size_t out = fx_out_len;
    unsigned rx = rx_tail, sets = ring_tail;
    uint8_t ready = console_ready();
    if (still >= 4) {
      next = end;
      if (tx_fill && tx_next_ns < next)
        next = tx_next_ns;
      if (running && next_tick_ns < next)
        next = next_tick_ns;
      if (rx_queue_pos < rx_queue_len && rx_next_ns < next)
        next = rx_next_ns;
      if (next < now_ns + 20000u)
        next = now_ns + 20000u;
    }
    advance_to(next);
    if (rx_gap_why & UART_READ_RING) /* marked as bytes arrive, cleared as read */
      ring_full = 1;
    if (rx_gap_more)
      gaps_merged = 1;
    loop_pass(); /* main.c's loop body */
    still = (out == fx_out_len && rx == rx_tail && sets == ring_tail && ready == console_ready() &&
             !settings_saving() && !loop_has_work()) ?
                still + 1 :
                0;
  }
}

/* What is queued for the wire: bytes and whether the USART loses them (1:
 * an overrun, 2: a framing error). */
static uint8_t pending[1 << 16], pending_lost[1 << 16];
static size_t npending;
static uint64_t last_arrival_ns; /* of the last byte sent */

/* The line's timeout is measured in Timer0 ticks (26 ms): silences within
 * TIMEOUT_MARGIN_MS of it could go either way, so none is made. */
#define TIMEOUT_MARGIN_MS 100u

/* Send what is queued and let it all arrive, plus `extra_us`. */
static void flush(uint64_t extra_us)
{
  size_t i = 0, first = nsent - npending;
  if (npending) {
    /* the first byte's silence, kept clear of the timeout */
    uint64_t at = now_ns + BYTE_NS, silence = at - last_arrival_ns;
    uint64_t lo = (CONSOLE_TIMEOUT_MS - TIMEOUT_MARGIN_MS) * 1000000ull;
    uint64_t hi = (CONSOLE_TIMEOUT_MS + TIMEOUT_MARGIN_MS) * 1000000ull;
    if (nsent > npending && silence >= lo && silence <= hi)
      run_us((hi - silence) / 1000u + 1u);
  }
  while (i < npending) {
    size_t n = 1;
    while (i + n < npending && pending_lost[i + n] == pending_lost[i])
      n++;
    (pending_lost[i] == 2 ? fx_send_frame_error :
     pending_lost[i]      ? fx_send_overrun :
                            fx_send)((const char *)pending + i, n);
    i += n;
  }
  if (npending) {
    /* the fake's schedule: back to back from rx_next_ns */
    uint64_t t = rx_next_ns + (uint64_t)(rx_queue_len - rx_queue_pos - npending) * BYTE_NS;
    for (i = 0; i < npending; i++)
      arrival[first + i] = t + i * BYTE_NS;
    last_arrival_ns = arrival[first + npending - 1];
    run_us(npending * (BYTE_NS / 1000u + 1u));
    npending = 0;
  }
  if (extra_us)
    run_us(extra_us);
}

static void put_as(uint8_t c, uint8_t is_lost)
{
  if (nsent < sizeof sent && npending < sizeof pending) {
    sent[nsent] = c;
    lost[nsent++] = is_lost;
    pending_lost[npending] = is_lost;
    pending[npending++] = c;
  }
}

static void put(uint8_t c)
{
  put_as(c, 0);
}

/* A pause of the sender, within the input's allowance. */
#define PAUSE_MAX_MS 5000u
static uint64_t paused_us;

static void pause(uint64_t us)
{
  if (paused_us + us > PAUSE_MAX_MS * 1000u)
    us = PAUSE_MAX_MS * 1000u - paused_us;
  paused_us += us;
  flush(us);
}

/* A data overrun (how 1): n bytes on the wire that the USART loses (the
 * next one comes with DOR set); framing errors (how 2): n bytes with FE. */
static void overrun(const uint8_t **p, const uint8_t *end, unsigned n, uint8_t how)
{
  while (n-- && *p < end && **p != 0xFF)
    put_as(*(*p)++, how);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
  (void)argc;
  (void)argv;
  memset(fake_eeprom, 0xFF, sizeof fake_eeprom); /* blank: default settings */
  fx_boot(0x01);                                 /* power-on */
  fx_run_us(50000);                              /* its boot line out */
  image_save();
  return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  const uint8_t *p = data, *end = data + size;
  size_t j = 0, k, probe_at, before = 0;
  int attempt;

  image_restore();
  nsent = npending = nparsed = 0;
  paused_us = 0;
  ring_full = gaps_merged = 0;
  parse_overflow = 0;
  while (p < end) {
    uint8_t c = *p++;
    if (c != 0xFF) {
      put(c);
      continue;
    }
    uint8_t o = p < end ? *p++ : 0, a = o >> 3;
    switch (o & 7) {
    case 0:
      for (const char *s = COMMANDS[a % NCOMMANDS]; *s; s++)
        put((uint8_t)*s);
      put('\r');
      break;
    case 1: pause((a + 1u) * 8000u); break;
    case 2: overrun(&p, end, a % 8u + 1u, 1); break;
    case 5: overrun(&p, end, a % 8u + 1u, 2); break;
    case 3: put(0xFF); break;
    case 4:
      pause((CONSOLE_TIMEOUT_MS + 3u * TIMEOUT_MARGIN_MS) * 1000u); /* an open line times out */
      break;
    default: pause(a * 1000u); break;
    }
  }
  /* The probe: a quiet moment, Ctrl-C to drop whatever line is open, a
   * clean line.  First back to back (Ctrl-C before a command must work in
   * every mode), then as a patient user sends it, with a quiet moment
   * after the Ctrl-C too, a second apart: its bytes may have been lost
   * then, and the device may refuse such a line, not stay deaf. */
  for (attempt = 0; attempt < PROBE_TRIES; attempt++) {
    before = nparsed;
    flush(PROBE_QUIET_MS * 1000u);
    put(attempt ? 0x1B : 0x03); /* Esc the second time */
    if (attempt)
      flush(PROBE_QUIET_MS * 1000u);
    for (const char *s = PROBE; *s; s++)
      put((uint8_t)*s);
    probe_at = nsent;
    put('\r');
    flush(0);
    for (k = 0; k < 1000u && !(nparsed > before && strcmp(parsed[nparsed - 1], PROBE) == 0); k++)
      run_us(1000);
    if (k < 1000u)
      break;
  }

  nmodel = build_model();
  if (getenv("FUZZ_LINE_TRACE")) { /* replaying one input: what happened */
    for (k = 0; k < nmodel; k++)
      fprintf(stderr, "model %zu: \"%s\"\n", k, model[k].text);
    for (k = 0; k < nparsed; k++)
      fprintf(stderr, "parsed %zu: \"%s\"\n", k, parsed[k]);
    fprintf(stderr, "device time %llu ms; output:\n%s\n", (unsigned long long)(fx_now_us() / 1000u), fx_out);
  }
  FUZZ_CHECK(!parse_overflow, "more than %d lines parsed", MAX_LINES);
  for (k = 0; k < nparsed; k++) {
    const char *t = parsed[k];
    if (!*t)
      continue; /* an empty text runs nothing */
    while (j < nmodel && strcmp(model[j].text, t) != 0)
      j++;
    FUZZ_CHECK(j < nmodel, "parsed \"%s\" (#%zu), not a clean line sent after the last one run", t, k);
    j++;
  }
  /* the last attempt ran: parsed after it was sent, the last line sent */
  FUZZ_CHECK(attempt < PROBE_TRIES && nparsed > before && strcmp(parsed[nparsed - 1], PROBE) == 0 && nmodel &&
                 model[nmodel - 1].end == probe_at,
             "deaf: the probe line \"" PROBE "\" did not run, sent %d times, quiet moments around "
             "Ctrl-C/Esc (mode %u, echo %u)",
             PROBE_TRIES, settings.mode, settings.echo);
  FUZZ_CHECK(attempt == 0,
             "Ctrl-C then \"" PROBE "\" back to back, after a quiet moment: the line "
             "did not run (it did when sent again slowly; mode %u, echo %u)",
             settings.mode, settings.echo);
  /* Its own RX ring never full (the fake's mark of it), the device lost nothing
   * but the bytes the model knows, and no gaps merged: then every clean line
   * ran, in order (the empty texts aside). */
  if (!ring_full && !gaps_merged) {
    size_t m = 0;
    for (k = 0; k < nparsed; k++)
      if (*parsed[k]) {
        FUZZ_CHECK(m < nmodel && strcmp(parsed[k], model[m].text) == 0,
                   "no ring overflow, yet clean line #%zu \"%s\" did not run (parsed \"%s\" instead)", m,
                   m < nmodel ? model[m].text : "", parsed[k]);
        m++;
      }
    FUZZ_CHECK(m == nmodel, "no ring overflow, yet %zu of %zu clean lines ran", m, nmodel);
  }
  return 0;
}
