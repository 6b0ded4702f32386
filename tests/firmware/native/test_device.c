/*
 * Native tests of the firmware's control and output path: the real output
 * scheduler, producers, command execution and settings, run by the main
 * loop's body against the fakes of fixture.h.  Each test is a power-up in
 * its own process (ctest runs `test_device <name>`).  Values are checked
 * against independent computations written here: the CRCs bit by bit, the
 * codes from the fake ADC's pattern, the fields from the commands sent.
 */
#define _GNU_SOURCE /* memmem */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fixture.h"
#include "unity.h"
#include <avr/eeprom.h>
#include <avr/io.h>
#include "ref_crc16.h"

void setUp(void) {}
void tearDown(void) {}

static unsigned ref_crc16_modbus(const uint8_t *p, size_t n);
static unsigned ref_crc16_modbus_more(unsigned reg, const uint8_t *p, size_t n);

/* The n-th line starting with prefix, its CRC verified; fails if absent. */
static void line(const char *prefix, unsigned n, char *body, size_t size)
{
  unsigned crc;
  char msg[96];
  snprintf(msg, sizeof msg, "no line #%u starting '$%s'", n, prefix);
  TEST_ASSERT_TRUE_MESSAGE(fx_find_line(prefix, n, body, size, &crc) >= 0, msg);
  TEST_ASSERT_EQUAL_HEX16_MESSAGE(ref_crc16(body, strlen(body)), crc, body);
}

/* Every framed line in the output is whole: `$`, printable body, `*`, four
 * upper-case hex digits, CR LF, with its CRC right. */
static void assert_all_lines_whole(void)
{
  const char *p = fx_out;
  unsigned lines = 0;
  while ((p = strchr(p, '$')) != NULL) {
    const char *q = p + 1;
    while (*q >= 0x20 && *q <= 0x7E && *q != '*' && *q != '$')
      q++;
    TEST_ASSERT_EQUAL_CHAR_MESSAGE('*', *q, p);
    TEST_ASSERT_EQUAL_UINT(ref_crc16(p + 1, (size_t)(q - p - 1)), (unsigned)strtoul(q + 1, NULL, 16));
    for (int i = 1; i <= 4; i++)
      TEST_ASSERT_TRUE(strchr("0123456789ABCDEF", q[i]) != NULL);
    TEST_ASSERT_EQUAL_CHAR('\r', q[5]);
    TEST_ASSERT_EQUAL_CHAR('\n', q[6]);
    p = q + 7;
    lines++;
  }
  TEST_ASSERT_TRUE(lines > 0);
}

/* The value of key in a `k=v,k=v` or `k=v k=v` body, as a string. */
static const char *field(const char *body, const char *key)
{
  static char v[64];
  size_t klen = strlen(key);
  const char *p = body;
  while ((p = strstr(p, key)) != NULL) {
    if (p[klen] == '=' && (p == body || p[-1] == ',' || p[-1] == ' ')) {
      size_t n = strcspn(p + klen + 1, ", ");
      memcpy(v, p + klen + 1, n);
      v[n] = 0;
      return v;
    }
    p++;
  }
  return "(absent)";
}

/* One command line, then time for its reply (commands sent back to back
 * while output is busy are the RX test's business, not these tests'). */
static void command(const char *text)
{
  fx_send_str(text);
  fx_send_str("\r");
  fx_run_us(60000);
}

static void test_boot_line_names_protocol_version_and_reset_cause(void)
{
  char b[256];
  fx_boot(0x02 | 0x08); /* EXTRF | WDRF */
  fx_run_us(20000);
  line("B,", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("1", field(b, "proto"));
  TEST_ASSERT_EQUAL_STRING("ext+wdt", field(b, "reset"));
}

static void test_status_reply_is_framed_and_checksummed(void)
{
  char b[256];
  fx_boot(1);
  fx_run_us(50000);
  fx_send_str("status\r");
  fx_run_us(50000);
  line("ok status", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING(
      "ok status run=1 mode=allan range=1.5 units=phys cfg=blank fs=100 interval=60 link=0 rx=0:0:0:0", b);
  assert_all_lines_whole();
}

static void test_unknown_command_gets_error_and_sampling_goes_on(void)
{
  char b[256];
  fx_boot(1);
  fx_send_str("bogus 12\r");
  fx_run_us(100000);
  line("error:", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("error:1 bogus: unknown command; see help", b);
  fx_send_str("stop\r");
  fx_run_us(50000);
  line("ok stopped", 0, b, sizeof b);
  /* every set made so far went to the engine */
  char want[64];
  snprintf(want, sizeof want, "ok stopped n=%u", (unsigned)fx_sets_made);
  TEST_ASSERT_EQUAL_STRING(want, b);
  TEST_ASSERT_TRUE(fx_sets_made >= 9);
}

static void test_reply_between_report_lines_pauses_report(void)
{
  char b[256];
  fx_boot(1);
  fx_run_us(3000000); /* 300 sets */
  fx_send_str("report\r");
  fx_run_us(60000);
  TEST_ASSERT_TRUE(fx_count_lines("L,") > 0); /* the report is under way */
  TEST_ASSERT_EQUAL_UINT(0, fx_count_lines("E,"));
  fx_send_str("status\r");
  fx_run_us(500000); /* the rest of the report: about 4.7 kB at 11.5 kB/s */
  long st = fx_find_line("ok status", 0, b, sizeof b, NULL);
  long h = fx_find_line("H,0,", 0, b, sizeof b, NULL);
  long e = fx_find_line("E,0,", 0, b, sizeof b, NULL);
  TEST_ASSERT_TRUE(h >= 0 && st > h && e > st); /* the reply came inside the report */
  line("E,0,", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("E,0,90", b);
  TEST_ASSERT_EQUAL_UINT(90, fx_count_lines("L,0,"));
  /* rows in order: channel by channel, level by level, none repeated or lost */
  for (unsigned i = 0; i < 90; i++) {
    char want[16];
    static const char *ch[] = {"ax", "ay", "az", "gx", "gy", "gz"};
    line("L,0,", i, b, sizeof b);
    snprintf(want, sizeof want, "L,0,%s,%u,", ch[i / 15], i % 15);
    TEST_ASSERT_EQUAL_STRING_LEN(want, b, strlen(want));
  }
  assert_all_lines_whole();
}

static void test_rate_change_resets_run(void)
{
  char b[256];
  fx_boot(1);
  fx_run_us(1000000);
  fx_send_str("rate 200\r");
  fx_run_us(50000);
  line("ok", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok reset rate=200", b);
  uint32_t before = fx_sets_made;
  fx_send_str("rate 200\r"); /* the same rate: no new run */
  fx_run_us(50000);
  line("ok", 1, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok rate=200", b);
  fx_send_str("stop\r");
  fx_run_us(50000);
  line("ok stopped", 0, b, sizeof b);
  unsigned n = (unsigned)strtoul(b + strlen("ok stopped n="), NULL, 10);
  /* only the sets since the change, at 200 Hz: about 0.1 s of them */
  TEST_ASSERT_TRUE(n <= fx_sets_made - (before - 10));
  TEST_ASSERT_TRUE(n >= 15 && n <= 30);
  fx_send_str("report\r");
  fx_run_us(400000);
  line("H,", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("200", field(b, "fs"));
  char want[16];
  snprintf(want, sizeof want, "%u", n);
  TEST_ASSERT_EQUAL_STRING(want, field(b, "n"));
}

static void test_range_command_drives_gselect_pins(void)
{
  static const struct {
    const char *word;
    unsigned pd6, pd7;
  } cases[] = {{"4", 0, 1}, {"2", 1, 0}, {"6", 1, 1}, {"1.5", 0, 0}};
  char cmd[32], b[256], want[64];
  fx_boot(1);
  TEST_ASSERT_EQUAL_HEX8(0xC0, fake_ddrd & 0xC0); /* both pins are outputs */
  for (unsigned i = 0; i < 4; i++) {
    snprintf(cmd, sizeof cmd, "range %s\r", cases[i].word);
    fx_send_str(cmd);
    fx_run_us(60000);
    line("ok", i, b, sizeof b);
    snprintf(want, sizeof want, "ok reset range=%s", cases[i].word);
    TEST_ASSERT_EQUAL_STRING(want, b);
    TEST_ASSERT_EQUAL_UINT(cases[i].pd6, (fake_portd >> 6) & 1u);
    TEST_ASSERT_EQUAL_UINT(cases[i].pd7, (fake_portd >> 7) & 1u);
  }
}

static void test_raw_mode_writes_every_set_in_order_with_count_lines(void)
{
  char b[256];
  fx_boot(1);
  fx_send_str("mode raw\r");
  fx_run_us(1500000);
  line("ok mode=raw", 0, b, sizeof b);
  /* after the reply: rows of the new run, each the fake ADC's codes */
  const char *p = strstr(fx_out, "ok mode=raw");
  p = strchr(p, '\n') + 1;
  unsigned rows = 0;
  long first = -1;
  while (*p && *p != '$') {
    unsigned c[7];
    TEST_ASSERT_EQUAL_INT(
        7, sscanf(p, "%u\t%u\t%u\t%u\t%u\t%u\t%u", &c[0], &c[1], &c[2], &c[3], &c[4], &c[5], &c[6]));
    if (first < 0) { /* which set the run starts at: find it */
      for (uint32_t i = 0; i < fx_sets_made && first < 0; i++)
        if (fx_code(i, 0) == c[0] && fx_code(i, 6) == c[6])
          first = (long)i;
      TEST_ASSERT_TRUE(first >= 0);
    }
    for (int k = 0; k < 7; k++)
      TEST_ASSERT_EQUAL_UINT(fx_code((uint32_t)first + rows, (uint8_t)k), c[k]);
    rows++;
    p = strchr(p, '\n') + 1;
  }
  TEST_ASSERT_EQUAL_UINT(100, rows); /* then the count line, with the CRC of the rows */
  const char *rows_start = strchr(strstr(fx_out, "ok mode=raw"), '\n') + 1;
  unsigned crc = ref_crc16_modbus((const uint8_t *)rows_start, (size_t)(p - rows_start));
  char want[32];
  snprintf(want, sizeof want, "C,100,0,%04X", crc);
  line("C,", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING(want, b);
  assert_all_lines_whole();
}

static unsigned ref_crc16_modbus_more(unsigned reg, const uint8_t *p, size_t n)
{
  for (size_t i = 0; i < n; i++)
    for (int b = 0; b < 8; b++) {
      unsigned in = (p[i] >> b) & 1u, low = reg & 1u;
      reg >>= 1;
      if (low ^ in)
        reg ^= 0xA001;
    }
  return reg;
}

static unsigned ref_crc16_modbus(const uint8_t *p, size_t n)
{
  /* CRC-16/MODBUS from its definition (reflected 0xA001 from 0xFFFF, a bit
   * at a time), independent of firmware/crc.c's byte-wise update. */
  return ref_crc16_modbus_more(0xFFFF, p, n);
}

static void test_save_writes_a_checked_record_and_load_restores_it(void)
{
  char b[256];
  fx_boot(1);
  fx_run_us(60000);
  command("rate 50");
  command("interval 7");
  command("mode both");
  command("range 4");
  command("save");
  line("ok saved", 0, b, sizeof b);
  /* the record: version 2, rate LE, interval LE, mode, range, echo, CRC big-endian */
  static const uint8_t want[8] = {2, 50, 0, 7, 0, 3, 2, 1};
  TEST_ASSERT_EQUAL_HEX8_ARRAY(want, fake_eeprom, 8);
  unsigned crc = ref_crc16_modbus(fake_eeprom, 8);
  TEST_ASSERT_EQUAL_HEX8(crc >> 8, fake_eeprom[8]);
  TEST_ASSERT_EQUAL_HEX8(crc & 0xFF, fake_eeprom[9]);
  fx_send_str("defaults\r");
  fx_run_us(100000);
  line("ok defaults", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok defaults reset", b);
  command("load");
  command("status");
  line("ok loaded", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok loaded reset", b);
  line("ok status", 0, b, sizeof b);
  /* link: 50 rows of 36 bytes and half a 31-byte count line a second, of
   * 11520 bytes/s: 1816 / 11520 = 15.8 %, rounded up */
  TEST_ASSERT_EQUAL_STRING(
      "ok status run=1 mode=both range=4 units=phys cfg=saved fs=50 interval=7 link=16 rx=0:0:0:0", b);
}

static void test_saved_settings_are_in_force_at_power_up(void)
{
  char b[256];
  static const uint8_t rec[8] = {2, 0xF4, 1, 5, 0, 0, 3, 0}; /* 500 Hz, 5 s, allan, 6 g, no echo */
  memcpy(fake_eeprom, rec, 8);
  unsigned crc = ref_crc16_modbus(rec, 8);
  fake_eeprom[8] = (uint8_t)(crc >> 8);
  fake_eeprom[9] = (uint8_t)crc;
  memset(fake_eeprom + 10, 0xFF, sizeof fake_eeprom - 10);
  fx_boot(1);
  fx_send_str("status\r");
  fx_run_us(100000);
  line("ok status", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING(
      "ok status run=1 mode=allan range=6 units=phys cfg=saved fs=500 interval=5 link=0 rx=0:0:0:0", b);
  TEST_ASSERT_EQUAL_UINT(3, (fake_portd >> 6) & 3u);
}

static void test_periodic_report_follows_the_interval(void)
{
  char b[512];
  fx_boot(1);
  fx_send_str("interval 1\r");
  fx_run_us(3500000);
  TEST_ASSERT_EQUAL_UINT(3, fx_count_lines("E,"));
  for (unsigned i = 0; i < 3; i++) {
    char h[8];
    snprintf(h, sizeof h, "H,%u,", i);
    line(h, 0, b, sizeof b);
    unsigned n = (unsigned)strtoul(field(b, "n"), NULL, 10);
    /* each header comes when a second of sets (100) is in */
    TEST_ASSERT_TRUE(n >= 100 * (i + 1) && n <= 100 * (i + 1) + 10);
    TEST_ASSERT_EQUAL_STRING("0", field(b, "drops"));
  }
  assert_all_lines_whole();
}

static void test_link_budget_refuses_raw_at_1000_hz(void)
{
  char b[256];
  fx_boot(1);
  fx_run_us(60000);
  command("rate 1000");
  command("mode raw");
  line("error:", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("error:4 mode: link too slow; lower rate", b);
}

/* Half a unit in the third significant digit of v, plus the device's
 * fixed-point error (fmt_adev: below 1e-4 relative). */
static double printed_tol(double v)
{
  return 0.5 * pow(10.0, floor(log10(v)) - 2) * 1.0001 + 2e-4 * v;
}

/* The T lines (N and B read on the device in fixed point) against N and B
 * computed here in double from the same report's L rows, on many reports:
 * four rates, runs of different lengths, each stopped then reported. */
static void test_noise_terms_match_float_on_many_reports(void)
{
  static const unsigned rates[] = {50, 100, 250, 1000};
  char b[256], cmd[32];
  unsigned seq = 0, checked = 0;
  fx_boot(1);
  fx_run_us(60000);
  command("echo off");
  command("interval 0"); /* reports only on request: seq counts ours */
  for (unsigned r = 0; r < 4; r++) {
    snprintf(cmd, sizeof cmd, "rate %u", rates[r]);
    command(cmd);
    for (unsigned run = 0; run < 3; run++, seq++) {
      unsigned n = 300u + 1700u * run + 37u * r; /* 300 .. 3500 sets */
      command("stop");
      command("reset");
      snprintf(cmd, sizeof cmd, "start %u", n);
      command(cmd);
      fx_run_us((uint64_t)n * 1000000u / rates[r] + 100000u);
      command("report");
      fx_run_us(700000);
      for (unsigned c = 0; c < 6; c++) {
        static const char *chs[] = {"ax", "ay", "az", "gx", "gy", "gz"};
        double adev[15];
        unsigned long pairs[15];
        int kn = -1, kb = -1;
        for (unsigned k = 0; k < 15; k++) {
          char pre[24], hex[16];
          unsigned lv;
          snprintf(pre, sizeof pre, "L,%u,%s,%u,", seq, chs[c], k);
          line(pre, 0, b, sizeof b);
          TEST_ASSERT_EQUAL_INT(3, sscanf(b + strlen(pre) - 2 - (k > 9), "%u,%lu,%12s", &lv, &pairs[k], hex));
          hex[12] = 0;
          double acc = (double)strtoull(hex, NULL, 16), m = (double)(1u << k);
          adev[k] = pairs[k] ? sqrt(acc / (2.0 * m * m * (double)pairs[k])) : 0.0;
          if (pairs[k] && (kn < 0 || fabs(m - rates[r]) < fabs((double)(1u << kn) - rates[r])))
            kn = (int)k;
          if (pairs[k] >= 8 && (kb < 0 || adev[k] < adev[kb]))
            kb = (int)k;
        }
        char pre[16];
        int tkn, tkb;
        double tn, tb;
        snprintf(pre, sizeof pre, "T,%u,%s,", seq, chs[c]);
        line(pre, 0, b, sizeof b);
        TEST_ASSERT_EQUAL_INT(4, sscanf(b + strlen(pre), "%d,%lf,%d,%lf", &tkn, &tn, &tkb, &tb));
        double wn = adev[kn] * sqrt((double)(1u << kn) / rates[r]), wb = adev[kb] / 0.664;
        TEST_ASSERT_EQUAL_INT_MESSAGE(kn, tkn, b);
        TEST_ASSERT_TRUE_MESSAGE(fabs(tn - wn) <= printed_tol(wn), b);
        TEST_ASSERT_TRUE_MESSAGE(tkb == kb || fabs(adev[tkb] - adev[kb]) <= 2e-4 * adev[kb], b);
        TEST_ASSERT_TRUE_MESSAGE(fabs(tb - wb) <= printed_tol(wb), b);
        checked++;
      }
    }
  }
  TEST_ASSERT_EQUAL_UINT(4 * 3 * 6, checked);
}

/* The thesis board's value of one count, worked out here from the data
 * sheets (independently of firmware/units.h): 10-bit ADC on 3.3 V,
 * MMA7260Q 800/600/300/200 mV/g at 1.5/2/4/6 g, LISY300AL 3.3 mV/(deg/s).
 * By quantity (0 deviation: mg, deg/s; 1 N: m/s/sqrt(h), deg/sqrt(h); 2 B
 * per count of deviation: mg, deg/h), channel and range; 1 in counts. */
static double unit_factor(int q, unsigned ch, unsigned range, int counts)
{
  static const double sens_v_per_g[] = {0.8, 0.6, 0.3, 0.2};
  double volt = 3.3 / 1024.0;
  if (counts)
    return 1.0;
  if (ch < 3) {
    double g = volt / sens_v_per_g[range];
    return q == 1 ? g * 9.80665 * 60.0 : g * 1000.0;
  }
  return volt / 0.0033 * (q == 0 ? 1.0 : q == 1 ? 60.0 : 3600.0);
}

/* A cell of 3 significant digits within the printed precision of v. */
static void assert_printed(double v, const char *cell, const char *where)
{
  char msg[160];
  double shown = strtod(cell, NULL);
  snprintf(msg, sizeof msg, "%s: shows %s, float gives %.6g", where, cell, v);
  TEST_ASSERT_TRUE_MESSAGE(v == 0 ? shown == 0 : fabs(shown - v) <= printed_tol(v), msg);
}

/* The summary a person reads (S lines), every range in both units, against
 * the values computed here in double from the same report's L rows: the
 * title, each level's deviations, and the terms (N at its tau, B with its
 * tau, the uncertainties 100/sqrt(2 pairs)); the summary comes last, right
 * before E, in at most 22 lines of at most 80 characters. */
static void test_summary_in_physical_units_matches_float_on_many_reports(void)
{
  static const char *chs[] = {"ax", "ay", "az", "gx", "gy", "gz"};
  static const char *ranges[] = {"1.5", "2", "4", "6"};
  static const unsigned rates[] = {100, 250};
  char b[256], cmd[32], want[96], pre[32];
  unsigned seq = 0, cells = 0;
  fx_boot(1);
  fx_run_us(60000);
  command("echo off");
  command("interval 0");
  for (unsigned u = 0; u < 2; u++) {
    command(u ? "units counts" : "units phys");
    line("ok units", 0 + u, b, sizeof b);
    TEST_ASSERT_EQUAL_STRING(u ? "ok units=counts" : "ok units=phys", b);
    for (unsigned r = 0; r < 4; r++, seq++) {
      unsigned fs = rates[(r + u) % 2], n = 900u + 1300u * r + 211u * u;
      snprintf(cmd, sizeof cmd, "range %s", ranges[r]);
      command(cmd);
      snprintf(cmd, sizeof cmd, "rate %u", fs);
      command(cmd);
      command("stop");
      command("reset");
      snprintf(cmd, sizeof cmd, "start %u", n);
      command(cmd);
      fx_run_us((uint64_t)n * 1000000u / fs + 100000u);
      command("report");
      fx_run_us(900000);
      snprintf(pre, sizeof pre, "H,%u,", seq);
      line(pre, 0, b, sizeof b);
      TEST_ASSERT_EQUAL_STRING(u ? "counts" : "phys", field(b, "units"));
      TEST_ASSERT_EQUAL_STRING(ranges[r], field(b, "range"));
      /* the L rows, in double */
      double adev[6][15];
      unsigned long pairs[15];
      unsigned levels = 0;
      for (unsigned c = 0; c < 6; c++)
        for (unsigned k = 0; k < 15; k++) {
          char hex[16];
          unsigned lv;
          snprintf(pre, sizeof pre, "L,%u,%s,%u,", seq, chs[c], k);
          line(pre, 0, b, sizeof b);
          TEST_ASSERT_EQUAL_INT(3, sscanf(b + strlen(pre) - 2 - (k > 9), "%u,%lu,%12s", &lv, &pairs[k], hex));
          double acc = (double)strtoull(hex, NULL, 16), m = (double)(1u << k);
          adev[c][k] = pairs[k] ? sqrt(acc / (2.0 * m * m * (double)pairs[k])) : 0.0;
          if (pairs[k] && k >= levels)
            levels = k + 1;
        }
      /* the S lines: framed width, count, and last before E */
      snprintf(pre, sizeof pre, "S,%u,", seq);
      unsigned ns = fx_count_lines(pre);
      TEST_ASSERT_EQUAL_UINT(2 + levels + 5, ns);
      TEST_ASSERT_TRUE(ns <= 22);
      for (unsigned i = 0; i < ns; i++) {
        line(pre, i, b, sizeof b);
        TEST_ASSERT_TRUE_MESSAGE(strlen(b) + 6 <= 80, b); /* $ body *XXXX */
      }
      {
        char e[32];
        long last = fx_find_line(pre, ns - 1, b, sizeof b, NULL);
        snprintf(e, sizeof e, "E,%u,", seq);
        long end = fx_find_line(e, 0, b, sizeof b, NULL);
        TEST_ASSERT_TRUE(last >= 0 && strchr(fx_out + last, '\n') + 1 == fx_out + end);
      }
      line(pre, 0, b, sizeof b);
      if (u)
        snprintf(want, sizeof want, "S,%u,Allan deviation by tau (s): ADC counts", seq);
      else
        snprintf(want, sizeof want, "S,%u,Allan deviation by tau (s): accel mg at +-%s g, gyro deg/s", seq,
                 ranges[r]);
      TEST_ASSERT_EQUAL_STRING(want, b);
      for (unsigned k = 0; k < levels; k++) {
        char cell[7][16];
        line(pre, 2 + k, b, sizeof b);
        TEST_ASSERT_EQUAL_INT(7, sscanf(b + strlen(pre), "%15s %15s %15s %15s %15s %15s %15s", cell[0],
                                        cell[1], cell[2], cell[3], cell[4], cell[5], cell[6]));
        assert_printed((double)(1u << k) / fs, cell[0], "tau");
        for (unsigned c = 0; c < 6; c++, cells++)
          assert_printed(adev[c][k] * unit_factor(0, c, r, u), cell[1 + c], b);
      }
      /* the terms: N at the level nearest 1 s (ties: the lower), B the least
       * deviation / 0.664 over levels with 8 pairs and more */
      int kn = -1;
      for (unsigned k = 0; k < levels; k++)
        if (kn < 0 || fabs((double)(1u << k) - fs) < fabs((double)(1u << kn) - fs))
          kn = (int)k;
      double ntau, npct;
      line(pre, 2 + levels, b, sizeof b);
      TEST_ASSERT_EQUAL_INT_MESSAGE(2, sscanf(b + strlen(pre), "N at %lf s +-%lf%%", &ntau, &npct), b);
      TEST_ASSERT_NOT_NULL_MESSAGE(
          strstr(b, u ? "%: count rt(s); B: counts" : "%: m/s/rt(h), deg/rt(h); B: mg, deg/h"), b);
      assert_printed((double)(1u << kn) / fs, strstr(b, "at ") + 3, "N tau");
      assert_printed(100.0 / sqrt(2.0 * pairs[kn]), strstr(b, "+-") + 2, "N +-%");
      char row[4][7][16];
      for (unsigned i = 0; i < 4; i++) {
        line(pre, 3 + levels + i, b, sizeof b);
        TEST_ASSERT_EQUAL_INT(7, sscanf(b + strlen(pre), "%15s %15s %15s %15s %15s %15s %15s", row[i][0],
                                        row[i][1], row[i][2], row[i][3], row[i][4], row[i][5], row[i][6]));
      }
      TEST_ASSERT_EQUAL_STRING("N", row[0][0]);
      TEST_ASSERT_EQUAL_STRING("B", row[1][0]);
      TEST_ASSERT_EQUAL_STRING("+-%", row[2][0]);
      TEST_ASSERT_EQUAL_STRING("tau_s", row[3][0]);
      for (unsigned c = 0; c < 6; c++, cells += 4) {
        int kb = -1;
        for (unsigned k = 0; k < levels; k++)
          if (pairs[k] >= 8 && (kb < 0 || adev[c][k] < adev[c][kb]))
            kb = (int)k;
        /* a near tie of the minimum may fall either way in fixed point */
        double shown_tau = strtod(row[3][1 + c], NULL);
        for (unsigned k = 0; k < levels; k++)
          if (pairs[k] >= 8 &&
              fabs(shown_tau - (double)(1u << k) / fs) <= printed_tol((double)(1u << k) / fs) &&
              fabs(adev[c][k] - adev[c][kb]) <= 2e-4 * adev[c][kb])
            kb = (int)k;
        assert_printed(adev[c][kn] * sqrt((double)(1u << kn) / fs) * unit_factor(1, c, r, u), row[0][1 + c],
                       "N");
        assert_printed(adev[c][kb] / 0.664 * unit_factor(2, c, r, u), row[1][1 + c], "B");
        assert_printed(100.0 / sqrt(2.0 * pairs[kb]), row[2][1 + c], "B +-%");
        assert_printed((double)(1u << kb) / fs, row[3][1 + c], "B tau");
      }
    }
  }
  TEST_ASSERT_TRUE(cells > 8 * 6 * 10);
  assert_all_lines_whole();
}

/* `units` typed while a report is sent takes effect with the next report:
 * a report's summary is in the units its header says. */
static void test_units_typed_during_a_report_apply_to_the_next(void)
{
  char b[256];
  fx_boot(1);
  fx_run_us(3000000);
  command("echo off");
  command("interval 0");
  fx_send_str("report\r");
  fx_run_us(60000); /* the report is under way */
  TEST_ASSERT_TRUE(fx_count_lines("L,0,") > 0 && fx_count_lines("E,0,") == 0);
  command("units counts");
  fx_run_us(900000);
  line("ok units", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok units=counts", b);
  line("H,0,", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("phys", field(b, "units"));
  line("S,0,", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("S,0,Allan deviation by tau (s): accel mg at +-1.5 g, gyro deg/s", b);
  TEST_ASSERT_EQUAL_UINT(1, fx_count_lines("E,0,"));
  command("report");
  fx_run_us(900000);
  line("H,1,", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("counts", field(b, "units"));
  line("S,1,", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("S,1,Allan deviation by tau (s): ADC counts", b);
}

static void test_line_with_nul_is_refused_whole_and_runs_nothing(void)
{
  static const char *bad[] = {"reset\0xyz", "rate 250\0 junk", "status\x01", "help\xff", "\0"};
  static const size_t len[] = {9, 14, 7, 5, 1};
  /* the bad byte shows as '?' in the quoted first word (6 characters) */
  static const char *quote[] = {"reset?", "rate", "status", "help?", "?"};
  char b[256], want[64];
  fx_boot(1);
  fx_run_us(1000000);
  for (unsigned i = 0; i < 5; i++) {
    fx_send(bad[i], len[i]);
    fx_send_str("\r");
    fx_run_us(60000);
    line("error:", i, b, sizeof b);
    snprintf(want, sizeof want, "error:6 %s: bad byte; printable ASCII", quote[i]);
    TEST_ASSERT_EQUAL_STRING(want, b);
  }
  command("stop");
  line("ok stopped", 0, b, sizeof b);
  snprintf(want, sizeof want, "ok stopped n=%u", (unsigned)fx_sets_made); /* never reset */
  TEST_ASSERT_EQUAL_STRING(want, b);
  TEST_ASSERT_EQUAL_UINT(0, fx_count_lines("ok status"));
}

static void test_backspace_and_delete_erase_the_last_character(void)
{
  char b[256];
  fx_boot(1);
  fx_run_us(60000);
  command("stattus\b\b\bus");
  line("ok status", 0, b, sizeof b);
  command("rate 2000\x7f\x7f"
          "0");
  line("ok", 1, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok reset rate=200", b);
}

static void test_report_header_temp_is_dash_or_mean_min_max(void)
{
  char b[512];
  unsigned dashes = 0;
  fx_boot(1);
  for (unsigned i = 0; i < 40; i++) {
    fx_run_us(2000 + 1370u * i); /* every phase against the 10 ms tick */
    fx_send_str("reset\rreport\r");
    fx_run_us(400000);
  }
  TEST_ASSERT_EQUAL_UINT(40, fx_count_lines("E,"));
  for (unsigned i = 0; i < 40; i++) {
    line("H,", i, b, sizeof b);
    const char *t = field(b, "temp");
    unsigned q, tenth, lo, hi;
    char end;
    if (strcmp(t, "-") == 0) {
      dashes++;
      continue;
    }
    TEST_ASSERT_EQUAL_INT_MESSAGE(4, sscanf(t, "%u.%u:%u:%u%c", &q, &tenth, &lo, &hi, &end), t);
    TEST_ASSERT_TRUE(lo <= q && q <= hi && tenth <= 9);
  }
  TEST_ASSERT_TRUE(dashes < 40);
}

/* A record with a good CRC whose rate/mode pair the link cannot carry. */
static void test_infeasible_saved_settings_load_defaults_and_say_so(void)
{
  char b[256];
  /* record v2: raw at 1000 Hz, interval 5, range 1.5 g, echo on */
  static const uint8_t rec[8] = {2, 0xE8, 3, 5, 0, 1, 0, 1};
  memcpy(fake_eeprom, rec, 8);
  unsigned crc = ref_crc16_modbus(rec, 8);
  fake_eeprom[8] = (uint8_t)(crc >> 8);
  fake_eeprom[9] = (uint8_t)crc;
  memset(fake_eeprom + 10, 0xFF, sizeof fake_eeprom - 10);
  fx_boot(1);
  fx_run_us(60000);
  command("status");
  line("ok status", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING(
      "ok status run=1 mode=allan range=1.5 units=phys cfg=infeasible fs=100 interval=60 link=0 rx=0:0:0:0",
      b);
  command("load");
  line("error:", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("error:4 load: link too slow; lower rate", b);
}

/* A record with a good CRC loads only with its flag byte's bits 2..7
 * clear (echo and units are bits 0 and 1): with any of them set it is
 * refused as corrupt and the settings in force stay. */
static void write_record(const uint8_t rec[8])
{
  unsigned crc = ref_crc16_modbus(rec, 8);
  memcpy(fake_eeprom, rec, 8);
  fake_eeprom[8] = (uint8_t)(crc >> 8);
  fake_eeprom[9] = (uint8_t)crc;
}

static void test_saved_record_with_a_spare_bit_set_is_refused(void)
{
  char b[256];
  /* record v2: allan at 250 Hz, interval 5, range 2 g, echo on, units counts */
  uint8_t rec[8] = {2, 250, 0, 5, 0, 0, 1, 3};
  unsigned bit;
  fx_boot(1);
  fx_run_us(60000);
  for (bit = 2; bit < 8; bit++) {
    rec[7] = (uint8_t)(3u | (1u << bit));
    write_record(rec);
    command("load");
    line("error:", bit - 2, b, sizeof b);
    TEST_ASSERT_EQUAL_STRING("error:4 load: nothing saved; save first", b);
  }
  rec[7] = 3;
  write_record(rec);
  command("load");
  line("ok loaded", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok loaded reset", b);
  command("status");
  line("ok status", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING(
      "ok status run=1 mode=allan range=2 units=counts cfg=saved fs=250 interval=5 link=0 rx=0:0:0:0", b);
}

/* CRC-16/MODBUS over the bodies of report seq's H and L lines, in order. */
static unsigned bound_crc(unsigned seq)
{
  char prefix[16], body[512];
  unsigned crc = 0xFFFF;
  for (int kind = 0; kind < 2; kind++) {
    snprintf(prefix, sizeof prefix, "%c,%u,", kind ? 'L' : 'H', seq);
    for (unsigned i = 0; fx_find_line(prefix, i, body, sizeof body, NULL) >= 0; i++) {
      const uint8_t *b = (const uint8_t *)body;
      size_t n = strlen(body);
      crc = ref_crc16_modbus_more(crc, b, n);
      if (!kind)
        break; /* one header */
    }
  }
  return crc;
}

static void test_report_check_line_binds_rows_to_header(void)
{
  char b[512], want[64], id[16];
  fx_boot(1);
  fx_run_us(2000000);
  command("report");
  fx_run_us(600000);
  line("H,0,", 0, b, sizeof b);
  snprintf(id, sizeof id, "%s", field(b, "id"));
  line("V,0,", 0, b, sizeof b);
  snprintf(want, sizeof want, "V,0,id=%s,crc=%04X", id, bound_crc(0));
  TEST_ASSERT_EQUAL_STRING(want, b);
  /* V ends the machine lines: after the last T, right before the first S
   * (the summary a person reads, last before E) */
  long v = fx_find_line("V,0,", 0, b, sizeof b, NULL);
  long t = fx_find_line("T,0,gz,", 0, b, sizeof b, NULL);
  long s0 = fx_find_line("S,0,", 0, b, sizeof b, NULL);
  long e = fx_find_line("E,0,", 0, b, sizeof b, NULL);
  TEST_ASSERT_TRUE(t >= 0 && v > t && strchr(fx_out + t, '\n') + 1 == fx_out + v);
  TEST_ASSERT_TRUE(s0 > v && strchr(fx_out + v, '\n') + 1 == fx_out + s0 && e > s0);
  assert_all_lines_whole();
}

static void test_seq_advances_when_a_report_starts_and_reset_changes_id(void)
{
  char b[512], id0[16];
  fx_boot(1);
  fx_run_us(2000000);
  command("report");
  fx_run_us(50000); /* the report is under way: cut it off */
  TEST_ASSERT_TRUE(fx_count_lines("L,0,") > 0);
  command("reset");
  command("report");
  fx_run_us(600000);
  TEST_ASSERT_EQUAL_UINT(0, fx_count_lines("E,0,")); /* report 0 never ended */
  line("H,0,", 0, b, sizeof b);
  snprintf(id0, sizeof id0, "%s", field(b, "id"));
  line("H,1,", 0, b, sizeof b);                        /* the next report has the next seq */
  TEST_ASSERT_FALSE(strcmp(id0, field(b, "id")) == 0); /* and another run */
  line("E,1,", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("E,1,90", b);
  line("V,1,", 0, b, sizeof b);
  char head[512], want[64];
  line("H,1,", 0, head, sizeof head);
  snprintf(want, sizeof want, "V,1,id=%s,crc=%04X", field(head, "id"), bound_crc(1));
  TEST_ASSERT_EQUAL_STRING(want, b);
}

/* `start <count>` means n = count when it stops, through a reset. */
static void test_start_count_stops_at_count_through_a_reset(void)
{
  char b[256];
  fx_boot(1);
  fx_run_us(60000);
  command("stop");
  command("reset");
  command("start 300");
  fx_run_us(1000000); /* about 100 sets in */
  command("reset");
  fx_run_us(4000000);
  command("status");
  line("ok status", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("run=0", strstr(b, "run=0") ? "run=0" : b);
  command("stop");
  line("ok stopped", 1, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok stopped n=300", b);
}

/* A rate change starts a new run and keeps the count (docs/protocol.md). */
static void test_start_count_is_kept_through_a_rate_change(void)
{
  char b[256];
  fx_boot(1);
  fx_run_us(60000);
  command("stop");
  command("reset");
  command("start 300");
  fx_run_us(1000000);
  command("rate 200");
  line("ok reset rate", 0, b, sizeof b);
  fx_run_us(3000000);
  command("stop");
  line("ok stopped", 1, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok stopped n=300", b);
}

/* The console's line discipline (docs/protocol.md, "Commands"). */

/* Offset of the first occurrence of text in the output at or after from, or -1. */
static long out_find(const char *text, long from)
{
  const char *p = memmem(fx_out + from, fx_out_len - (size_t)from, text, strlen(text));
  return p ? p - fx_out : -1;
}

/* Occurrences of text in the whole output (binary frames hold NULs). */
static unsigned out_count(const char *text)
{
  unsigned n = 0;
  for (long at = out_find(text, 0); at >= 0; at = out_find(text, at + 1))
    n++;
  return n;
}

static void test_stray_byte_without_end_delays_no_report_and_times_out(void)
{
  char b[512];
  long x, h, rx;
  fx_boot(1);
  fx_run_us(50000);
  command("interval 2"); /* the first report after 200 sets: at 2 s */
  fx_run_us(1000000 - fx_now_us());
  fx_send_str("x"); /* at 1 s, and nothing more */
  fx_run_us(2500000 - fx_now_us());
  /* the report came on time, the echo line ended before it */
  h = fx_find_line("H,0,", 0, b, sizeof b, NULL);
  TEST_ASSERT_TRUE_MESSAGE(h >= 0, "the report waited on a half-typed line");
  x = out_find("> x\r\n", 0);
  TEST_ASSERT_TRUE(x >= 0 && x < h);
  TEST_ASSERT_EQUAL_UINT(0, fx_count_lines("error:"));
  /* 2 s of silence after the x (it arrived at 1.0 s): refused, once */
  fx_run_us(2990000 - fx_now_us());
  TEST_ASSERT_EQUAL_UINT(0, fx_count_lines("error:"));
  fx_run_us(3100000 - fx_now_us());
  line("error:", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("error:7 x: timed out; resend", b);
  /* shown again whole before its reply, after the report */
  rx = fx_find_line("error:7", 0, b, sizeof b, NULL);
  x = out_find("> x\r\n", x + 1);
  TEST_ASSERT_TRUE(x > h && x < rx);
  fx_run_us(2000000);
  TEST_ASSERT_EQUAL_UINT(1, fx_count_lines("error:"));
  line("H,1,", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("0:0:0:1", field(b, "rx"));
  command("status");
  line("ok status", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("0:0:0:1", field(b, "rx"));
}

static void test_line_that_lost_a_byte_to_an_overrun_is_refused_whole(void)
{
  char b[256];
  fx_boot(1);
  fx_run_us(50000);
  /* "rate 200" whose second 0 the USART lost: never run as "rate 20" */
  fx_send_str("rate 20");
  fx_send_overrun("0", 1);
  fx_send_str("\r");
  fx_run_us(60000);
  line("error:", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("error:5 rate: input lost; resend", b);
  /* the end of the line lost: glued to the next, refused with it */
  fx_send_str("interval 36");
  fx_send_overrun("00\r", 3);
  fx_send_str("status\r");
  fx_run_us(60000);
  line("error:", 1, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("error:5 interv: input lost; resend", b);
  TEST_ASSERT_EQUAL_UINT(0, fx_count_lines("ok"));
  command("status");
  line("ok status", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("100", field(b, "fs"));
  TEST_ASSERT_EQUAL_STRING("60", field(b, "interval"));
  TEST_ASSERT_EQUAL_STRING("2:0:2:0", field(b, "rx"));
}

/* Commands sent back to back while a long reply keeps the device from
 * reading: the RX ring overflows again and again.  Every command either
 * runs as sent or is refused with error:5; none is glued to another. */
static void test_back_to_back_commands_run_as_sent_or_get_error_5(void)
{
  static const char *cmds[] = {"status",   "interval 3600", "rate 1000",    "report", "interval 17",
                               "rate 250", "echo on",       "units counts", "reset"};
  static const char *ok[] = {"ok status ", "ok interval=3600", "ok reset rate=1000",
                             "ok",         "ok interval=17",   "ok reset rate=250",
                             "ok echo=on", "ok units=counts",  "ok reset"};
  const unsigned n = sizeof cmds / sizeof cmds[0];
  char b[512];
  unsigned runs = 0, lost = 0;
  fx_boot(1);
  fx_run_us(50000);
  for (unsigned round = 0; round < 6; round++) {
    fx_send_str("help\r"); /* 15 lines: the next commands wait in the ring */
    for (unsigned i = 0; i < n; i++) {
      fx_send_str(cmds[(i + round) % n]);
      fx_send_str("\r");
    }
    fx_run_us(3000000);
  }
  for (unsigned k = 0; fx_find_line("ok", k, b, sizeof b, NULL) >= 0; k++) {
    int known = strncmp(b, "ok help ", 8) == 0;
    for (unsigned i = 0; i < n && !known; i++)
      known = i == 0 ? strncmp(b, ok[0], strlen(ok[0])) == 0 : strcmp(b, ok[i]) == 0;
    TEST_ASSERT_TRUE_MESSAGE(known, b);
    runs += strncmp(b, "ok help ", 8) != 0;
  }
  for (unsigned k = 0; fx_find_line("error:", k, b, sizeof b, NULL) >= 0; k++) {
    TEST_ASSERT_EQUAL_STRING_LEN_MESSAGE("error:5 ", b, 8, b);
    lost++;
  }
  /* the ring did overflow, and some commands still got through */
  TEST_ASSERT_TRUE(lost > 0);
  TEST_ASSERT_TRUE(runs > 0);
  command("status");
  line("ok status", fx_count_lines("ok status") - 1, b, sizeof b);
  {
    unsigned ovr, ring, lines, timeouts;
    TEST_ASSERT_EQUAL_INT(4, sscanf(field(b, "rx"), "%u:%u:%u:%u", &ovr, &ring, &lines, &timeouts));
    TEST_ASSERT_EQUAL_UINT(0, ovr);
    TEST_ASSERT_TRUE(ring > 0);
    TEST_ASSERT_EQUAL_UINT(lost, lines);
    TEST_ASSERT_EQUAL_UINT(0, timeouts);
  }
}

/* Ctrl-C or Esc, then a command at once, in every mode: the command runs
 * (no false error:5), nothing is replied to the dropped line. */
static void test_ctrl_c_or_esc_then_a_command_runs_in_every_mode(void)
{
  static const char *modes[] = {"binary", "raw", "both", "allan"};
  char b[256], want[64];
  fx_boot(1);
  fx_run_us(50000);
  command("rate 50"); /* every mode fits the link at 50 Hz */
  for (unsigned i = 0; i < 4; i++) {
    snprintf(want, sizeof want, "mode %s", modes[i]);
    command(want);
    fx_send_str(i & 1 ? "\x1bmode allan\r" : "st\x03mode allan\r");
    fx_run_us(200000);
    fx_send_str(i & 1 ? "\x1b" : "\x03");
    snprintf(want, sizeof want, "mode %s\r", modes[i]);
    fx_send_str(want);
    fx_run_us(200000);
  }
  TEST_ASSERT_EQUAL_UINT(0, out_count("$error:"));
  TEST_ASSERT_EQUAL_UINT(6, out_count("$ok mode=allan*"));
  TEST_ASSERT_EQUAL_UINT(2, out_count("$ok mode=binary*"));
  TEST_ASSERT_EQUAL_UINT(2, out_count("$ok mode=raw*"));
  TEST_ASSERT_EQUAL_UINT(2, out_count("$ok mode=both*"));
  (void)b;
}

/* A line on the screen that Ctrl-C drops is marked "^C" and ended; the
 * echo of a line that runs ends (CR LF) before its reply. */
static void test_dropped_line_is_marked_on_the_screen(void)
{
  long e, r;
  fx_boot(1);
  fx_run_us(50000);
  fx_send_str("repo");
  fx_run_us(100000);
  fx_send_str("\x03");
  fx_run_us(100000);
  TEST_ASSERT_TRUE(out_find("> repo^C\r\n", 0) >= 0);
  fx_send_str("status\r");
  fx_run_us(100000);
  e = out_find("> status\r\n", 0);
  r = out_find("$ok status", 0);
  TEST_ASSERT_TRUE(e >= 0 && r == e + 10);
  TEST_ASSERT_EQUAL_UINT(0, fx_count_lines("ok report"));
  TEST_ASSERT_EQUAL_UINT(0, fx_count_lines("H,"));
  TEST_ASSERT_EQUAL_UINT(0, fx_count_lines("error:"));
}

/* "text*XXXX": the text and the line check a host appends (docs/protocol.md,
 * "Commands"), the CRC computed here bit by bit. */
static void with_check(char *out, size_t size, const char *text)
{
  snprintf(out, size, "%s*%04X", text, ref_crc16(text, strlen(text)));
}

/* A command with its check runs as sent; one whose text or check changed
 * on the way (a bit flipped into another printable character) is refused
 * whole with error:5, runs nothing and counts as a lost line; a command
 * without a check runs as typed. */
static void test_command_check_runs_as_sent_or_refuses_a_changed_line(void)
{
  char b[256], l[32];
  fx_boot(1);
  fx_run_us(50000);
  with_check(l, sizeof l, "interval 36");
  command(l);
  line("ok interval", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok interval=36", b);
  TEST_ASSERT_TRUE(out_find("> interval 36\r\n", 0) >= 0); /* the check is not echoed */
  l[10] ^= 0x01;                                           /* "interval 37" with the check of "interval 36" */
  command(l);
  line("error:", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("error:5 interv: input lost; resend", b);
  with_check(l, sizeof l, "interval 17");
  l[strlen(l) - 1] ^= 0x02; /* a bit of the check's last digit */
  command(l);
  line("error:", 1, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING_LEN("error:5 ", b, 8);
  /* malformed: too few digits, too many, lower case, nothing after '*' */
  with_check(l, sizeof l, "interval 18");
  l[strlen(l) - 1] = 0;
  command(l);
  with_check(l, sizeof l, "interval 19");
  strcat(l, "0");
  command(l);
  command("interval 20*abcd");
  command("interval 21*");
  TEST_ASSERT_EQUAL_UINT(6, fx_count_lines("error:5 "));
  TEST_ASSERT_EQUAL_UINT(1, fx_count_lines("ok interval"));
  /* no check: typed by a person, it runs */
  command("interval 22");
  line("ok interval", 1, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok interval=22", b);
  /* the check does not count against the 16 characters of a line */
  with_check(l, sizeof l, "start 4294967295");
  command(l);
  line("ok started", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok started", b);
  with_check(l, sizeof l, "status");
  command(l);
  line("ok status", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("22", field(b, "interval"));
  TEST_ASSERT_EQUAL_STRING("0:0:6:0", field(b, "rx"));
  TEST_ASSERT_EQUAL_UINT(0, fx_count_lines("error:3"));
  /* a stray '*' alone times out like any open line, glued to nothing */
  fx_send_str("*");
  fx_run_us(2100000);
  TEST_ASSERT_EQUAL_UINT(1, fx_count_lines("error:7"));
  command("interval 23");
  line("ok interval", 2, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING("ok interval=23", b);
}

static const struct {
  const char *name;
  void (*fn)(void);
} tests[] = {
#define T(f)                                                                                                 \
  {                                                                                                          \
#    f, f                                                                                                    \
  }
    T(test_boot_line_names_protocol_version_and_reset_cause),
    T(test_status_reply_is_framed_and_checksummed),
    T(test_unknown_command_gets_error_and_sampling_goes_on),
    T(test_reply_between_report_lines_pauses_report),
    T(test_rate_change_resets_run),
    T(test_range_command_drives_gselect_pins),
    T(test_raw_mode_writes_every_set_in_order_with_count_lines),
    T(test_save_writes_a_checked_record_and_load_restores_it),
    T(test_noise_terms_match_float_on_many_reports),
    T(test_summary_in_physical_units_matches_float_on_many_reports),
    T(test_units_typed_during_a_report_apply_to_the_next),
    T(test_saved_settings_are_in_force_at_power_up),
    T(test_periodic_report_follows_the_interval),
    T(test_link_budget_refuses_raw_at_1000_hz),
    T(test_line_with_nul_is_refused_whole_and_runs_nothing),
    T(test_backspace_and_delete_erase_the_last_character),
    T(test_report_header_temp_is_dash_or_mean_min_max),
    T(test_infeasible_saved_settings_load_defaults_and_say_so),
    T(test_saved_record_with_a_spare_bit_set_is_refused),
    T(test_report_check_line_binds_rows_to_header),
    T(test_seq_advances_when_a_report_starts_and_reset_changes_id),
    T(test_start_count_stops_at_count_through_a_reset),
    T(test_start_count_is_kept_through_a_rate_change),
    T(test_stray_byte_without_end_delays_no_report_and_times_out),
    T(test_line_that_lost_a_byte_to_an_overrun_is_refused_whole),
    T(test_back_to_back_commands_run_as_sent_or_get_error_5),
    T(test_ctrl_c_or_esc_then_a_command_runs_in_every_mode),
    T(test_dropped_line_is_marked_on_the_screen),
    T(test_command_check_runs_as_sent_or_refuses_a_changed_line),
#undef T
};

static void dump(void)
{
  fwrite(fx_out, 1, fx_out_len, stderr);
}

int main(int argc, char **argv)
{
  size_t i;
  if (argc < 2) { /* the list, for CMake */
    for (i = 0; i < sizeof tests / sizeof tests[0]; i++)
      printf("%s\n", tests[i].name);
    return 0;
  }
  if (getenv("FX_DUMP"))
    atexit(dump);
  UNITY_BEGIN();
  for (i = 0; i < sizeof tests / sizeof tests[0]; i++)
    if (strcmp(argv[1], tests[i].name) == 0)
      UnityDefaultTestRun(tests[i].fn, tests[i].name, __LINE__);
  return UNITY_END();
}
