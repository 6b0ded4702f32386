/*
 * test_device.c - native tests of the device's commands and saved settings:
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
#include <avr/eeprom.h>
#include <avr/io.h>
#include "ref_crc16.h"

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
  write_record(rec);
  fx_boot(1);
  fx_send_str("status\r");
  fx_run_us(100000);
  line("ok status", 0, b, sizeof b);
  TEST_ASSERT_EQUAL_STRING(
      "ok status run=1 mode=allan range=6 units=phys cfg=saved fs=500 interval=5 link=0 rx=0:0:0:0", b);
  TEST_ASSERT_EQUAL_UINT(3, (fake_portd >> 6) & 3u);
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

/* A record with a good CRC whose rate/mode pair the link cannot carry. */
static void test_infeasible_saved_settings_load_defaults_and_say_so(void)
{
  char b[256];
  /* record v2: raw at 1000 Hz, interval 5, range 1.5 g, echo on */
  static const uint8_t rec[8] = {2, 0xE8, 3, 5, 0, 1, 0, 1};
  write_record(rec);
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

static const struct device_test tests[] = {
    DEVICE_TEST(test_boot_line_names_protocol_version_and_reset_cause),
    DEVICE_TEST(test_status_reply_is_framed_and_checksummed),
    DEVICE_TEST(test_unknown_command_gets_error_and_sampling_goes_on),
    DEVICE_TEST(test_rate_change_resets_run),
    DEVICE_TEST(test_range_command_drives_gselect_pins),
    DEVICE_TEST(test_save_writes_a_checked_record_and_load_restores_it),
    DEVICE_TEST(test_saved_settings_are_in_force_at_power_up),
    DEVICE_TEST(test_link_budget_refuses_raw_at_1000_hz),
    DEVICE_TEST(test_infeasible_saved_settings_load_defaults_and_say_so),
    DEVICE_TEST(test_saved_record_with_a_spare_bit_set_is_refused),
    DEVICE_TEST(test_start_count_stops_at_count_through_a_reset),
    DEVICE_TEST(test_start_count_is_kept_through_a_rate_change),
};

DEVICE_MAIN(tests)
