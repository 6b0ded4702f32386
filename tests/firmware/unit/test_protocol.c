/*
 * Unity tests of the pure encoding modules: crc, fmt (number formatting
 * without printf or floats), proto (line framing) and command (parsing),
 * each against an independent computation written here.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "command.h"
#include "crc.h"
#include "link.h"
#include "fmt.h"
#include "units.h"
#include "proto.h"
#include "unity.h"

void setUp(void) {}
void tearDown(void) {}

static uint64_t rng = 88172645463325252ull;
static uint64_t next(void)
{
  rng ^= rng << 13;
  rng ^= rng >> 7;
  rng ^= rng << 17;
  return rng;
}

/* ---- crc ---- */
static uint16_t crc_ref(const char *s, size_t n)
{
  /* Table-free textbook CRC-16/CCITT-FALSE, bit by bit from the top. */
  uint32_t reg = 0xFFFF;
  for (size_t i = 0; i < n; i++)
    for (int b = 7; b >= 0; b--) {
      uint32_t in = ((uint8_t)s[i] >> b) & 1u, top = (reg >> 15) & 1u;
      reg = (reg << 1) & 0xFFFF;
      if (top ^ in)
        reg ^= 0x1021;
    }
  return (uint16_t)reg;
}

static void test_crc_check_value_and_random_strings(void)
{
  uint16_t c = CRC16_INIT;
  for (const char *p = "123456789"; *p; p++)
    c = crc16_update(c, (uint8_t)*p);
  TEST_ASSERT_EQUAL_HEX16(0x29B1, c);
  for (int t = 0; t < 200; t++) {
    char s[64];
    size_t n = next() % sizeof s;
    for (size_t i = 0; i < n; i++)
      s[i] = (char)next();
    c = CRC16_INIT;
    for (size_t i = 0; i < n; i++)
      c = crc16_update(c, (uint8_t)s[i]);
    TEST_ASSERT_EQUAL_HEX16(crc_ref(s, n), c);
  }
}

/* CRC-16/MODBUS: the catalogue's check value, and a bit-by-bit MSB-first
 * computation on bit-reversed bytes (an independent formulation). */
static unsigned rev(unsigned v, int bits)
{
  unsigned r = 0;
  for (int i = 0; i < bits; i++)
    r |= ((v >> i) & 1u) << (bits - 1 - i);
  return r;
}

static void test_crc_modbus_check_value_and_random_strings(void)
{
  uint16_t c = CRC16_MODBUS_INIT;
  for (const char *p = "123456789"; *p; p++)
    c = crc16_modbus_update(c, (uint8_t)*p);
  TEST_ASSERT_EQUAL_HEX16(0x4B37, c);
  for (int t = 0; t < 200; t++) {
    uint8_t s[64];
    size_t n = next() % sizeof s;
    uint32_t reg = 0xFFFF; /* reflected init 0xFFFF is 0xFFFF */
    for (size_t i = 0; i < n; i++) {
      s[i] = (uint8_t)next();
      unsigned in = rev(s[i], 8);
      for (int b = 7; b >= 0; b--) {
        unsigned top = (reg >> 15) & 1u;
        reg = (reg << 1) & 0xFFFF;
        if (top ^ ((in >> b) & 1u))
          reg ^= 0x8005;
      }
    }
    c = CRC16_MODBUS_INIT;
    for (size_t i = 0; i < n; i++)
      c = crc16_modbus_update(c, s[i]);
    TEST_ASSERT_EQUAL_HEX16(rev(reg, 16), c);
  }
}

/* ---- fmt ---- */
static void test_fmt_u32_and_hex_match_snprintf(void)
{
  uint32_t vals[] = {0, 1, 9, 10, 99, 100, 65535, 65536, 999999999u, 1000000000u, 4294967295u};
  char buf[16], ref[16];
  for (int t = 0; t < 1000 + 11; t++) {
    uint32_t v = t < 11 ? vals[t] : (uint32_t)(next() >> (next() % 32));
    uint8_t n = fmt_u32(buf, v);
    buf[n] = 0;
    snprintf(ref, sizeof ref, "%u", v);
    TEST_ASSERT_EQUAL_STRING(ref, buf);
    fmt_hex(buf, v, 8);
    buf[8] = 0;
    snprintf(ref, sizeof ref, "%08X", v);
    TEST_ASSERT_EQUAL_STRING(ref, buf);
  }
  fmt_hex(buf, 0xABCDu, 4);
  buf[4] = 0;
  TEST_ASSERT_EQUAL_STRING("ABCD", buf);
}

/* The printed text must be `value` to 3 significant digits, in the
 * protocol's notation, up to the stated 1e-4 relative slack. */
static void assert_sig3(const char *s, double value, const char *what)
{
  char msg[160];
  double p = strtod(s, NULL), e10 = floor(log10(value)), half = 0.5 * pow(10.0, e10 - 2);
  int digits = 0, leading = 1;
  snprintf(msg, sizeof msg, "%s: printed '%s' for %.9g", what, s, value);
  for (const char *c = s; *c && *c != 'e'; c++) {
    if (*c >= '1' && *c <= '9')
      leading = 0;
    if (*c >= '0' && *c <= '9' && !leading)
      digits++;
  }
  if (p >= 1000.0) /* r and zeros */
    TEST_ASSERT_TRUE_MESSAGE(digits >= 3 && strchr(s, '.') == NULL, msg);
  else
    TEST_ASSERT_EQUAL_INT_MESSAGE(3, digits, msg);
  /* e-notation below 0.001; between 0.0009995 and 0.001 the value rounds
   * to "0.00100", which is right too. */
  if (value < 0.0009995 || value >= 0.001)
    TEST_ASSERT_TRUE_MESSAGE((value < 0.001) == (strstr(s, "e-") != NULL), msg);
  TEST_ASSERT_TRUE_MESSAGE(fabs(p - value) <= half * 1.000001 + 1e-4 * value, msg);
}

static void adev_str(char *buf, uint16_t hi, uint32_t lo, uint32_t pairs, uint8_t level)
{
  uint32_t mant;
  int8_t exp = fmt_adev(&mant, hi, lo, pairs, level);
  fmt_sig3(buf, mant, exp);
}

static void tau_str(char *buf, uint8_t level, uint16_t fs)
{
  uint32_t mant;
  int8_t exp = fmt_tau(&mant, level, fs);
  fmt_sig3(buf, mant, exp);
}

static void test_fmt_adev_three_significant_digits(void)
{
  char buf[FMT_SIG3_MAX + 2];
  for (int t = 0; t < 20000; t++) {
    uint64_t acc = next() >> (16 + next() % 48);
    uint32_t pairs = (uint32_t)(next() >> (32 + next() % 32));
    uint8_t level = (uint8_t)(next() % 23);
    double value;
    uint8_t n;
    if (!pairs)
      pairs = 1;
    if (!acc)
      acc = 1;
    value = sqrt((double)acc / (2.0 * pairs)) / ldexp(1.0, level);
    {
      uint32_t mant;
      int8_t exp = fmt_adev(&mant, (uint16_t)(acc >> 32), (uint32_t)acc, pairs, level);
      n = fmt_sig3(buf, mant, exp);
    }
    TEST_ASSERT_EQUAL_UINT8(strlen(buf), n);
    TEST_ASSERT_TRUE(n < FMT_SIG3_MAX);
    assert_sig3(buf, value, "adev");
  }
  adev_str(buf, 0, 0, 5, 3);
  TEST_ASSERT_EQUAL_STRING("0", buf);
  /* A few by hand: sqrt(8/2)/1 = 2, sqrt(2e6/2)/4 = 250, sqrt(2/2)/1024. */
  adev_str(buf, 0, 8, 1, 0);
  TEST_ASSERT_EQUAL_STRING("2.00", buf);
  adev_str(buf, 0, 2000000, 1, 2);
  TEST_ASSERT_EQUAL_STRING("250", buf);
  adev_str(buf, 0, 2, 1, 10);
  TEST_ASSERT_EQUAL_STRING("9.77e-4", buf);
}

/* The unit factors of units.c against the thesis board's data sheets,
 * worked out here in double: a 10-bit ADC on 3.3 V, MMA7260Q 800/600/300/
 * 200 mV/g, LISY300AL 3.3 mV/(deg/s); quantity 0 deviation (mg, deg/s),
 * 1 N (m/s/sqrt(h), deg/sqrt(h)), 2 B = deviation / 0.664 (mg, deg/h);
 * kind 0 counts (B: / 0.664 only), 1..4 accelerometer ranges, 5 gyro. */
static double board_factor(int q, int kind)
{
  static const double sens[] = {0.8, 0.6, 0.3, 0.2};
  double volt = 3.3 / 1024.0, f;
  if (kind == UNITS_COUNTS)
    f = 1.0;
  else if (kind == UNITS_GYRO)
    f = volt / 0.0033 * (q == UNITS_N ? 60.0 : q == UNITS_B ? 3600.0 : 1.0);
  else
    f = volt / sens[kind - UNITS_ACC] * (q == UNITS_N ? 9.80665 * 60.0 : 1000.0);
  return q == UNITS_B ? f / 0.664 : f;
}

/* Random reports' deviations (random sums, pair counts and levels),
 * through fmt_adev, units_scale and fmt_sig3 as the summary prints them,
 * for every quantity, range and units, against double arithmetic. */
static void test_units_scale_matches_float_on_random_reports(void)
{
  char buf[FMT_SIG3_MAX + 2];
  unsigned checked = 0;
  for (int t = 0; t < 20000; t++) {
    uint64_t acc = next() >> (16 + next() % 48);
    uint32_t pairs = (uint32_t)(next() >> (32 + next() % 32));
    uint8_t level = (uint8_t)(next() % 15);
    int q = (int)(next() % UNITS_QUANTITIES), kind = (int)(next() % UNITS_KINDS);
    uint32_t mant;
    int8_t exp;
    double value;
    if (!pairs)
      pairs = 1;
    if (!acc)
      acc = 1;
    value = sqrt((double)acc / (2.0 * pairs)) / ldexp(1.0, level) * board_factor(q, kind);
    exp = fmt_adev(&mant, (uint16_t)(acc >> 32), (uint32_t)acc, pairs, level);
    TEST_ASSERT_TRUE(mant < 65536u); /* units_scale's precondition */
    exp = units_scale(&mant, exp, (uint8_t)q, (uint8_t)kind);
    fmt_sig3(buf, mant, exp);
    assert_sig3(buf, value, "scaled");
    checked++;
  }
  TEST_ASSERT_EQUAL_UINT(20000, checked);
  /* One count is 4.03 mg at 1.5 g and 0.977 deg/s (the thesis' resolution). */
  {
    uint32_t m = 1;
    int8_t e = units_scale(&m, 0, UNITS_ADEV, UNITS_ACC + RANGE_1G5);
    fmt_sig3(buf, m, e);
    TEST_ASSERT_EQUAL_STRING("4.03", buf);
    m = 1;
    e = units_scale(&m, 0, UNITS_ADEV, UNITS_GYRO);
    fmt_sig3(buf, m, e);
    TEST_ASSERT_EQUAL_STRING("0.977", buf);
  }
}

/* fmt_mean against 64-bit arithmetic: (10 sum + n / 2) / n tenths. */
static uint32_t mean_ref(uint64_t sum, uint32_t n)
{
  uint64_t t = (10u * sum + n / 2u) / n;
  return (uint32_t)(t / 10u) | (uint32_t)(t % 10u) << 16;
}

static uint32_t mean_of(uint64_t sum, uint32_t n)
{
  return fmt_mean(n, (uint32_t)sum, (uint8_t)(sum >> 32));
}

#define MEAN(whole, tenth) ((uint32_t)(whole) | (uint32_t)(tenth) << 16)

/* The report header's temperature mean over the longest interval (3600 s
 * at 1500 Hz: 5.4e6 sets of codes up to 1023, a sum of 5.5e9 > 2^32), at
 * its extremes and its rounding edges, and on random sums. */
static void test_fmt_mean_is_exact_over_an_hour_at_1500_hz(void)
{
  const uint32_t n = 3600u * 1500u;
  char msg[80];
  TEST_ASSERT_TRUE((uint64_t)1023u * n > 0xFFFFFFFFull);
  TEST_ASSERT_EQUAL_HEX32(MEAN(1023, 0), mean_of((uint64_t)1023u * n, n));
  TEST_ASSERT_EQUAL_HEX32(MEAN(1022, 9),
                          mean_of((uint64_t)1023u * n - n / 20u - 1u, n));           /* just under 1022.95 */
  TEST_ASSERT_EQUAL_HEX32(MEAN(1023, 0), mean_of((uint64_t)1023u * n - n / 20u, n)); /* 1022.95 */
  TEST_ASSERT_EQUAL_HEX32(MEAN(512, 5), mean_of((uint64_t)512u * n + n / 2u, n));
  TEST_ASSERT_EQUAL_HEX32(MEAN(0, 0), mean_of(0, n));
  TEST_ASSERT_EQUAL_HEX32(MEAN(7, 0), mean_of(7, 1));
  for (int i = 0; i < 200000; i++) {
    uint32_t m = 1u + (uint32_t)(next() % (i & 1 ? n : (1u << 28) - 1u));
    uint64_t sum = next() % ((uint64_t)1023u * m + 1u);
    snprintf(msg, sizeof msg, "sum %llu n %lu", (unsigned long long)sum, (unsigned long)m);
    TEST_ASSERT_EQUAL_HEX32_MESSAGE(mean_ref(sum, m), mean_of(sum, m), msg);
  }
}

static void test_fmt_tau_every_level_and_rate(void)
{
  static const uint16_t rates[] = {50, 100, 200, 250, 500, 1000, 1250, 1500};
  char buf[FMT_SIG3_MAX + 2];
  for (int r = 0; r < 8; r++)
    for (uint8_t k = 0; k < 23; k++) {
      tau_str(buf, k, rates[r]);
      assert_sig3(buf, ldexp(1.0, k) / rates[r], "tau");
    }
  tau_str(buf, 0, 100);
  TEST_ASSERT_EQUAL_STRING("0.0100", buf);
  tau_str(buf, 14, 100);
  TEST_ASSERT_EQUAL_STRING("164", buf);
  tau_str(buf, 22, 50);
  TEST_ASSERT_EQUAL_STRING("83900", buf);
}

/* ---- proto ---- */
static char out[512];
static size_t out_len;
static void sink(uint8_t c)
{
  if (out_len < sizeof out - 1)
    out[out_len++] = (char)c;
  out[out_len] = 0;
}

static void test_proto_frames_a_line_with_its_crc(void)
{
  char expect[128];
  const char *body = "L,3,gx,4,374,00000001A2F3,00";
  out_len = 0;
  proto_init(sink);
  proto_begin();
  proto_puts("L,");
  proto_u32(3);
  proto_puts(",gx,4,");
  proto_u32(374);
  proto_putc(',');
  proto_hex(0x0000, 4);
  proto_hex(0x0001A2F3, 8);
  proto_puts(",00");
  proto_end();
  snprintf(expect, sizeof expect, "$%s*%04X\r\n", body, crc_ref(body, strlen(body)));
  TEST_ASSERT_EQUAL_STRING(expect, out);
}

static void test_proto_never_lets_framing_characters_into_a_body(void)
{
  out_len = 0;
  proto_init(sink);
  proto_begin();
  proto_puts("a$b*c\r\n\x01");
  proto_end();
  TEST_ASSERT_EQUAL_STRING_LEN("$a?b?c???*", out, 10);
  TEST_ASSERT_EQUAL_INT(1, (int)(strchr(out + 1, '$') == NULL));
}

static void test_proto_binary_frame(void)
{
  /* The layout of docs/protocol.md, built by hand. */
  const uint8_t packed[9] = {0xF0, 0xEC, 0x16, 0x08, 0xF2, 0xF2, 0x3F, 0x9A, 0x01};
  uint8_t f[PROTO_FRAME_BYTES], body[10];
  body[0] = 0x2A;
  memcpy(body + 1, packed, 9);
  memset(f, 0, sizeof f);
  memcpy(f + 2, packed, 9); /* the caller's payload */
  proto_frame(f, 0x2A);
  TEST_ASSERT_EQUAL_HEX8(0xA5, f[0]);
  TEST_ASSERT_EQUAL_HEX8(0x2A, f[1]);
  TEST_ASSERT_EQUAL_MEMORY(packed, f + 2, 9);
  {
    char tmp[10];
    memcpy(tmp, body, 10);
    TEST_ASSERT_EQUAL_HEX16(crc_ref(tmp, 10), (uint16_t)(f[11] << 8 | f[12]));
  }
}

/* ---- command ---- */
static void test_command_words_and_arguments(void)
{
  command_t c;
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("report", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_REPORT, c.id);
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("  RePoRt  ", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_REPORT, c.id);
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_NONE, c.id);
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("start", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_START, c.id);
  TEST_ASSERT_EQUAL_UINT8(0, c.has_arg);
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("start 4294967295", &c));
  TEST_ASSERT_EQUAL_UINT32(4294967295u, c.arg);
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("start 4294967296", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("rate\t250", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_RATE, c.id);
  TEST_ASSERT_EQUAL_UINT32(250, c.arg);
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("rate", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("rate fast", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("rate 250 x", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("reset 3", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_UNKNOWN, command_parse("resets", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_UNKNOWN, command_parse("rep", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_UNKNOWN, command_parse("\x80\xff", &c));
  {
    /* Words longer than 255 characters once hung the parser (fuzzing). */
    static char big[600];
    memset(big, 'x', sizeof big - 1);
    TEST_ASSERT_EQUAL_UINT8(CMD_ERR_UNKNOWN, command_parse(big, &c));
    memcpy(big, "rate ", 5);
    TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse(big, &c));
  }
  TEST_ASSERT_TRUE(vocab_rate_ok(1000) && vocab_rate_ok(50) && !vocab_rate_ok(300) && !vocab_rate_ok(0));
  TEST_ASSERT_TRUE(vocab_rate_ok(1250) && vocab_rate_ok(1500) &&
                   !vocab_rate_ok(1600)); /* 1600: shorter than the scan */
}

static void test_command_settings_words(void)
{
  command_t c;
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("mode RAW", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_MODE, c.id);
  TEST_ASSERT_EQUAL_UINT32(MODE_RAW, c.arg);
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("mode both", &c));
  TEST_ASSERT_EQUAL_UINT32(MODE_BOTH, c.arg);
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("mode", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("mode ra", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("mode rawx", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("range 1.5", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_RANGE, c.id);
  TEST_ASSERT_EQUAL_UINT32(RANGE_1G5, c.arg);
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("range 6", &c));
  TEST_ASSERT_EQUAL_UINT32(RANGE_6G, c.arg);
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("range 3", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("range 1.", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("interval 3600", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_INTERVAL, c.id);
  TEST_ASSERT_EQUAL_UINT32(3600, c.arg);
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("interval", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("SAVE", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_SAVE, c.id);
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("defaults", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_DEFAULTS, c.id);
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("load", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_LOAD, c.id);
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("load now", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("help", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_HELP, c.id);
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("status", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_STATUS, c.id);
  /* units: phys (0) or counts (1), alone shows the setting */
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("units counts", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_UNITS, c.id);
  TEST_ASSERT_EQUAL_UINT32(1, c.arg);
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("UNITS Phys", &c));
  TEST_ASSERT_TRUE(c.has_arg && c.arg == 0);
  TEST_ASSERT_EQUAL_UINT8(CMD_OK, command_parse("units", &c));
  TEST_ASSERT_FALSE(c.has_arg);
  TEST_ASSERT_EQUAL_UINT8(CMD_ERR_ARG, command_parse("units mg", &c));
  TEST_ASSERT_EQUAL_UINT8(CMD_UNITS, c.id);
  TEST_ASSERT_EQUAL_STRING("binary", vocab_word(vocab_modes, MODE_BINARY));
  TEST_ASSERT_EQUAL_STRING("1.5", vocab_word(vocab_ranges, RANGE_1G5));
  TEST_ASSERT_EQUAL_STRING("6", vocab_word(vocab_ranges, RANGE_6G));
}

/* The link rules of docs/protocol.md, worked out by hand at 115200 baud
 * (11520 bytes/s; 90 % = 10368 usable).  A set's row or frame may wait
 * behind the longest line it cannot cut into (status: 131 bytes; the
 * header: 313) and one 20-byte output step, then its own row (36) or frame (13);
 * that must go out at the usable rate within two sample periods. */
static void test_link_budget(void)
{
  const uint32_t b = 115200;
  /* raw: 36 bytes a row + a 36-byte count line per 100 rows; 131 + 20 + 36
   * = 187 bytes of wait */
  TEST_ASSERT_EQUAL_UINT32(250u * 36u + (250u * 36u + 99u) / 100u, link_bytes_per_s(MODE_RAW, 250));
  TEST_ASSERT_EQUAL_UINT16(187, link_wait_bytes(MODE_RAW));
  TEST_ASSERT_TRUE(link_fits(MODE_RAW, 100, b));      /* 187 / 10368 s = 18.0 ms <= 20 ms */
  TEST_ASSERT_FALSE(link_fits(MODE_RAW, 200, b));     /* 18.0 ms > 10 ms: a status reply would cost a set */
  TEST_ASSERT_FALSE(link_fits(MODE_RAW, 250, b));     /* throughput fits (9090 B/s), the wait does not */
  TEST_ASSERT_FALSE(link_fits(MODE_RAW, 500, b));     /* 18155 B/s */
  TEST_ASSERT_FALSE(link_fits(MODE_RAW, 100, 57600)); /* 187 / 5184 s = 36 ms > 20 ms */
  TEST_ASSERT_TRUE(link_fits(MODE_RAW, 50, 57600));
  /* binary: 13 bytes a frame; frames cut into lines: 20 + 13 = 33 bytes of wait */
  TEST_ASSERT_EQUAL_UINT16(33, link_wait_bytes(MODE_BINARY));
  TEST_ASSERT_TRUE(link_fits(MODE_BINARY, 500, b));   /* 3.2 ms <= 4 ms */
  TEST_ASSERT_FALSE(link_fits(MODE_BINARY, 1000, b)); /* 13360 B/s */
  TEST_ASSERT_TRUE(link_fits(MODE_BINARY, 1000, 250000));
  /* both: 313 + 20 + 36 = 369 bytes of wait */
  TEST_ASSERT_EQUAL_UINT16(369, link_wait_bytes(MODE_BOTH));
  TEST_ASSERT_TRUE(link_fits(MODE_BOTH, 50, b)); /* 35.6 ms <= 40 ms */
  TEST_ASSERT_FALSE(link_fits(MODE_BOTH, 100, b));
  TEST_ASSERT_TRUE(link_fits(MODE_BOTH, 100, 250000)); /* 16.4 ms <= 20 ms */
  /* allan: reports wait for the link */
  TEST_ASSERT_TRUE(link_fits(MODE_ALLAN, 1000, 9600));
  TEST_ASSERT_EQUAL_UINT16(0, link_percent(MODE_ALLAN, 1000, b));
  TEST_ASSERT_EQUAL_UINT16(79, link_percent(MODE_RAW, 250, b)); /* 9090 / 11520 = 78.9 % */
}

/* The device's table (link_*_here, at this build's BAUD) gives what the
 * rules give for every supported rate and mode, in vocab_rates' order;
 * a rate that is not supported never fits. */
static void test_link_table_agrees_with_the_rules_at_baud(void)
{
  uint8_t i, mode;
  TEST_ASSERT_EQUAL_UINT32(115200, BAUD);
  for (i = 0; i < VOCAB_RATE_COUNT; i++) {
    uint16_t hz = vocab_rates[i];
    for (mode = 0; mode < VOCAB_MODES; mode++) {
      TEST_ASSERT_EQUAL_UINT8(link_fits(mode, hz, BAUD), link_fits_here(mode, hz));
      TEST_ASSERT_EQUAL_UINT16(link_percent(mode, hz, BAUD), link_percent_here(mode, hz));
    }
  }
  TEST_ASSERT_TRUE(link_fits_here(MODE_RAW, 100) && !link_fits_here(MODE_RAW, 200));
  TEST_ASSERT_TRUE(link_fits_here(MODE_BINARY, 500) && !link_fits_here(MODE_BINARY, 1000));
  TEST_ASSERT_EQUAL_UINT16(79, link_percent_here(MODE_RAW, 250));
  TEST_ASSERT_EQUAL_UINT16(145, link_percent_here(MODE_BINARY, 1250)); /* 16250 + 450 B/s of 11520 */
  TEST_ASSERT_FALSE(link_fits_here(MODE_ALLAN, 300));
  TEST_ASSERT_EQUAL_UINT16(0, link_percent_here(MODE_RAW, 300));
  TEST_ASSERT_EQUAL_UINT8(VOCAB_RATE_COUNT, vocab_rate_index(1600));
  TEST_ASSERT_EQUAL_UINT8(7, vocab_rate_index(1500));
  TEST_ASSERT_EQUAL_UINT8(6, vocab_rate_index(1250));
}

int main(void)
{
  UNITY_BEGIN();
  RUN_TEST(test_crc_check_value_and_random_strings);
  RUN_TEST(test_crc_modbus_check_value_and_random_strings);
  RUN_TEST(test_fmt_u32_and_hex_match_snprintf);
  RUN_TEST(test_fmt_adev_three_significant_digits);
  RUN_TEST(test_units_scale_matches_float_on_random_reports);
  RUN_TEST(test_fmt_mean_is_exact_over_an_hour_at_1500_hz);
  RUN_TEST(test_fmt_tau_every_level_and_rate);
  RUN_TEST(test_proto_frames_a_line_with_its_crc);
  RUN_TEST(test_proto_never_lets_framing_characters_into_a_body);
  RUN_TEST(test_proto_binary_frame);
  RUN_TEST(test_command_words_and_arguments);
  RUN_TEST(test_command_settings_words);
  RUN_TEST(test_link_budget);
  RUN_TEST(test_link_table_agrees_with_the_rules_at_baud);
  return UNITY_END();
}
