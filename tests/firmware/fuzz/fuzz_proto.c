/*
 * fuzz_proto - the line encoder (firmware/proto.c, crc.c, fmt.c) against an
 * independent decoder written here from docs/protocol.md.
 *
 * Input: 4 bytes choosing a corruption (kind, position, value, line), then
 * operations, each an opcode byte and its operands: proto_putc, proto_puts,
 * proto_puts_P, proto_u32, proto_hex (0..8 digits), or "end this line and
 * begin another".  A model of the expected body is kept alongside: bytes
 * outside the body's alphabet become '?', numbers are what snprintf prints.
 *
 * Checked:
 *   - fmt_u32 / fmt_hex write exactly snprintf's "%u" / low digits of "%08X",
 *     into heap blocks of exactly that size (no byte more);
 *   - the output is exactly one `$<body>*<4 uppercase hex>\r\n` per line
 *     begun, body printable ASCII 0x20-0x7E without `$` and `*`, equal to
 *     the model, CRC equal to a bitwise CRC-16/CCITT-FALSE computed here;
 *   - a receiver written here with the host's rules (split at `$`, a line
 *     ends at LF with an optional CR, body of at most 200 bytes, hex in
 *     either case) accepts the line with its body;
 *   - no corrupted line accepted: after one byte of a line is changed,
 *     dropped or inserted, the receiver accepts at most one body, and
 *       . a substitution that does not create a `$`: none, or the original
 *         body (CRC-16 detects every error confined to 16 bits);
 *       . any corruption: never a body of the original length other than
 *         the original.  (A dropped or inserted byte, or a `$` that restarts
 *         the line, shifts the frame; CRC-16 cannot promise to catch that, a
 *         2^-16 chance per corrupted line, so a collision there is legal.)
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crc.h"
#include "fmt.h"
#include "fuzz_util.h"
#include "proto.h"

#define MAX_BODY 200 /* docs/protocol.md: at most 200 characters */
#define MAX_LINES 8
#define OUT_MAX (MAX_LINES * (MAX_BODY + 16))

/* ---- what the encoder wrote ---- */
static uint8_t out[OUT_MAX];
static size_t out_len;
static int out_overflow;

static void sink(uint8_t c)
{
  if (out_len < sizeof out)
    out[out_len++] = c;
  else
    out_overflow = 1;
}

/* ---- the model ---- */
static char expect[MAX_LINES][MAX_BODY + 64];
static size_t expect_len[MAX_LINES];

static void model_putc(int line, uint8_t c)
{
  if (c == '$' || c == '*' || c < 0x20 || c > 0x7E)
    c = '?';
  expect[line][expect_len[line]++] = (char)c;
}

/* ---- independent CRC: the textbook bitwise CRC-16/CCITT-FALSE ---- */
static uint16_t crc_ref(const uint8_t *s, size_t n)
{
  uint32_t reg = 0xFFFF;
  for (size_t i = 0; i < n; i++)
    for (int b = 7; b >= 0; b--) {
      uint32_t in = (s[i] >> b) & 1u, top = (reg >> 15) & 1u;
      reg = (reg << 1) & 0xFFFF;
      if (top ^ in)
        reg ^= 0x1021;
    }
  return (uint16_t)reg;
}

static int body_char(uint8_t c)
{
  return c >= 0x20 && c <= 0x7E && c != '$' && c != '*';
}

static int hex_value(uint8_t c, int upper_only)
{
  if (c >= '0' && c <= '9')
    return c - '0';
  if (c >= 'A' && c <= 'F')
    return c - 'A' + 10;
  if (!upper_only && c >= 'a' && c <= 'f')
    return c - 'a' + 10;
  return -1;
}

/* ---- the receiver (host rules) ---- */
typedef struct {
  int count;
  size_t len; /* of the first accepted body */
  uint8_t body[MAX_BODY + 1];
} accepted_t;

static void receive(const uint8_t *s, size_t n, accepted_t *acc)
{
  size_t i = 0;
  acc->count = 0;
  while (i < n) {
    size_t start, end, b, lf;
    int h, crc = 0;
    while (i < n && s[i] != '$') /* garbage outside a line */
      i++;
    if (i == n)
      break;
    start = ++i;
    /* The segment runs to the next '$' (a restart) or the end. */
    end = start;
    while (end < n && s[end] != '$')
      end++;
    i = end;
    for (lf = start; lf < end && s[lf] != '\n'; lf++)
      ;
    if (lf == end) /* restarted or truncated: lost */
      continue;
    /* [start, lf) must be body '*' hex{4} '\r'? */
    for (b = start; b < lf && body_char(s[b]); b++)
      ;
    if (b - start > MAX_BODY || b >= lf || s[b] != '*')
      continue;
    if (lf - (b + 1) != 4 && !(lf - (b + 1) == 5 && s[lf - 1] == '\r'))
      continue;
    for (h = 0; h < 4; h++) {
      int v = hex_value(s[b + 1 + h], 0);
      if (v < 0)
        break;
      crc = crc << 4 | v;
    }
    if (h < 4 || crc != crc_ref(s + start, b - start))
      continue;
    if (!acc->count++) {
      acc->len = b - start;
      memcpy(acc->body, s + start, acc->len);
    }
  }
}

/* ---- operations ---- */
static void fmt_checks(uint32_t v, uint8_t digits)
{
  char ref[16];
  char *buf = malloc(10); /* fmt_u32 writes at most 10 digits, no NUL */
  uint8_t n = fmt_u32(buf, v);
  snprintf(ref, sizeof ref, "%u", v);
  FUZZ_CHECK(n == strlen(ref) && memcmp(buf, ref, n) == 0, "fmt_u32(%u) gave \"%.*s\"", v,
             (int)(n <= 10 ? n : 10), buf);
  free(buf);
  buf = malloc(digits); /* exactly `digits` bytes */
  fmt_hex(buf, v, digits);
  snprintf(ref, sizeof ref, "%08X", v);
  FUZZ_CHECK(memcmp(buf, ref + 8 - digits, digits) == 0, "fmt_hex(%08X, %u) gave \"%.*s\"", v, digits,
             (int)digits, buf);
  free(buf);
}

static char *heap_string(fuzz_in_t *in)
{
  /* Up to 31 bytes, stopping at a NUL, in a block of exactly its size. */
  size_t want = fz_u8(in) % 32u, n = 0;
  char *s;
  while (n < want && n < in->n && in->p[n])
    n++;
  s = malloc(n + 1);
  memcpy(s, in->p, n);
  s[n] = 0;
  in->p += n;
  in->n -= n;
  return s;
}

static void show_line(const char *what, const uint8_t *s, size_t n)
{
  fprintf(stderr, "%s: \"", what);
  for (size_t i = 0; i < n; i++)
    fprintf(stderr, (s[i] >= 0x20 && s[i] < 0x7F && s[i] != '"' && s[i] != '\\') ? "%c" : "\\x%02X", s[i]);
  fprintf(stderr, "\"\n");
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  fuzz_in_t in = {data, size};
  uint8_t kind = fz_u8(&in), value = fz_u8(&in), sel = fz_u8(&in);
  uint16_t pos = fz_u16(&in);
  int lines = 1, line;
  size_t line_start[MAX_LINES], line_len[MAX_LINES], p;

  out_len = 0;
  out_overflow = 0;
  memset(expect_len, 0, sizeof expect_len);
  proto_init(sink);
  proto_begin();
  while (in.n) {
    uint8_t op = fz_u8(&in) % 6u;
    char *s, *q;
    uint32_t v;
    uint8_t digits;
    char ref[16];
    if (expect_len[lines - 1] > 160) { /* keep bodies within MAX_BODY */
      if (lines == MAX_LINES)
        break;
      op = 5;
    }
    switch (op) {
    case 0:
      v = fz_u8(&in);
      proto_putc((char)v);
      model_putc(lines - 1, (uint8_t)v);
      break;
    case 1:
    case 2:
      s = heap_string(&in);
      if (op == 1)
        proto_puts(s);
      else
        proto_puts_P(s);
      for (q = s; *q; q++)
        model_putc(lines - 1, (uint8_t)*q);
      free(s);
      break;
    case 3:
      v = fz_u32(&in);
      fmt_checks(v, 8);
      proto_u32(v);
      snprintf(ref, sizeof ref, "%u", v);
      for (q = ref; *q; q++)
        model_putc(lines - 1, (uint8_t)*q);
      break;
    case 4:
      v = fz_u32(&in);
      digits = fz_u8(&in) % 9u;
      fmt_checks(v, digits);
      proto_hex(v, digits);
      snprintf(ref, sizeof ref, "%08X", v);
      for (q = ref + 8 - digits; *q; q++)
        model_putc(lines - 1, (uint8_t)*q);
      break;
    default:
      if (lines == MAX_LINES)
        break;
      proto_end();
      proto_begin();
      lines++;
      break;
    }
  }
  proto_end();
  FUZZ_CHECK(!out_overflow, "more output than %d bytes", OUT_MAX);

  /* Strict decoding: exactly the lines begun, each as the model says. */
  p = 0;
  for (line = 0; line < lines; line++) {
    size_t b, n = expect_len[line];
    int h, crc = 0;
    line_start[line] = p;
    FUZZ_CHECK(p < out_len && out[p] == '$', "line %d does not start with '$' at byte %zu", line, p);
    for (b = p + 1; b < out_len && out[b] != '*'; b++)
      FUZZ_CHECK(body_char(out[b]), "line %d: byte 0x%02X in the body", line, out[b]);
    FUZZ_CHECK(b - (p + 1) == n && memcmp(out + p + 1, expect[line], n) == 0,
               "line %d: body \"%.*s\", expected \"%.*s\"", line, (int)(b - (p + 1)), out + p + 1, (int)n,
               expect[line]);
    FUZZ_CHECK(b + 7 <= out_len, "line %d: truncated after its body", line);
    for (h = 0; h < 4; h++) {
      int v = hex_value(out[b + 1 + h], 1);
      FUZZ_CHECK(v >= 0, "line %d: CRC digit 0x%02X is not uppercase hex", line, out[b + 1 + h]);
      crc = crc << 4 | v;
    }
    FUZZ_CHECK(crc == crc_ref(out + p + 1, n), "line %d: CRC %04X, expected %04X", line, crc,
               crc_ref(out + p + 1, n));
    FUZZ_CHECK(out[b + 5] == '\r' && out[b + 6] == '\n', "line %d: not ended by CR LF", line);
    p = b + 7;
    line_len[line] = p - line_start[line];
  }
  FUZZ_CHECK(p == out_len, "%zu bytes after the last line", out_len - p);

  /* The receiver takes every line as it is. */
  for (line = 0; line < lines; line++) {
    accepted_t acc;
    receive(out + line_start[line], line_len[line], &acc);
    FUZZ_CHECK(acc.count == 1 && acc.len == expect_len[line] && memcmp(acc.body, expect[line], acc.len) == 0,
               "the receiver did not accept line %d", line);
  }

  /* No corrupted line accepted. */
  {
    uint8_t mut[MAX_BODY + 32];
    const uint8_t *orig;
    size_t n, mlen, body_len, at;
    accepted_t acc;
    int creates_dollar = 0;
    line = sel % lines;
    orig = out + line_start[line];
    n = line_len[line];
    body_len = expect_len[line];
    kind %= 3;
    if (kind == 0) { /* substitute: xor a non-zero value */
      at = pos % n;
      memcpy(mut, orig, n);
      mut[at] ^= value ? value : 0x80;
      mlen = n;
      creates_dollar = mut[at] == '$';
    } else if (kind == 1) { /* drop */
      at = pos % n;
      memcpy(mut, orig, at);
      memcpy(mut + at, orig + at + 1, n - at - 1);
      mlen = n - 1;
    } else { /* insert */
      at = pos % (n + 1);
      memcpy(mut, orig, at);
      mut[at] = value;
      memcpy(mut + at + 1, orig + at, n - at);
      mlen = n + 1;
      creates_dollar = value == '$';
    }
    receive(mut, mlen, &acc);
    if (acc.count) {
      int same = acc.len == body_len && memcmp(acc.body, expect[line], body_len) == 0;
      if (acc.count > 1 || (!same && (acc.len == body_len || (kind == 0 && !creates_dollar)))) {
        show_line("original ", orig, n);
        show_line("corrupted", mut, mlen);
        show_line("accepted ", acc.body, acc.len);
        FUZZ_CHECK(0, "a corrupted line was accepted (%d bodies; kind %u at byte %zu)", acc.count, kind, at);
      }
    }
  }
  return 0;
}
