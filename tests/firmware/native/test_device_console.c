/*
 * test_device_console.c - native tests of the console's line discipline
 * (docs/protocol.md, "Commands"):
 * the real output scheduler, producers, command execution and settings, run
 * by the main loop's body against the fakes of fixture.h (device_check.c:
 * the shared checks and runner).  Values are checked against independent
 * computations written here.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "device_check.h"
#include "fixture.h"
#include "unity.h"
#include "ref_crc16.h"

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

static const struct device_test tests[] = {
    DEVICE_TEST(test_line_with_nul_is_refused_whole_and_runs_nothing),
    DEVICE_TEST(test_backspace_and_delete_erase_the_last_character),
    DEVICE_TEST(test_stray_byte_without_end_delays_no_report_and_times_out),
    DEVICE_TEST(test_line_that_lost_a_byte_to_an_overrun_is_refused_whole),
    DEVICE_TEST(test_back_to_back_commands_run_as_sent_or_get_error_5),
    DEVICE_TEST(test_ctrl_c_or_esc_then_a_command_runs_in_every_mode),
    DEVICE_TEST(test_dropped_line_is_marked_on_the_screen),
    DEVICE_TEST(test_command_check_runs_as_sent_or_refuses_a_changed_line),
};

DEVICE_MAIN(tests)
