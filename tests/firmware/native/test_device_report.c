/*
 * test_device_report.c - native tests of the reports a terminal and the host read:
 * the real output scheduler, producers, command execution and settings, run
 * by the main loop's body against the fakes of fixture.h (device_check.c:
 * the shared checks and runner).  Values are checked against independent
 * computations written here.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "device_check.h"
#include "fixture.h"
#include "unity.h"
#include "ref_crc16.h"

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

static const struct device_test tests[] = {
    DEVICE_TEST(test_reply_between_report_lines_pauses_report),
    DEVICE_TEST(test_raw_mode_writes_every_set_in_order_with_count_lines),
    DEVICE_TEST(test_noise_terms_match_float_on_many_reports),
    DEVICE_TEST(test_summary_in_physical_units_matches_float_on_many_reports),
    DEVICE_TEST(test_units_typed_during_a_report_apply_to_the_next),
    DEVICE_TEST(test_periodic_report_follows_the_interval),
    DEVICE_TEST(test_report_header_temp_is_dash_or_mean_min_max),
    DEVICE_TEST(test_report_check_line_binds_rows_to_header),
    DEVICE_TEST(test_seq_advances_when_a_report_starts_and_reset_changes_id),
};

DEVICE_MAIN(tests)
