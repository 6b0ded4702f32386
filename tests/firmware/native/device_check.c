/*
 * device_check.c - what the native device tests share: reading the device's
 * framed lines (each CRC checked against the bit-wise reference), sending a
 * command, writing a saved-settings record the way `save` does, and the
 * runner each test file's main() calls.  Each test is a power-up in its own
 * process (ctest runs `<test file> <name>`).
 */
#define _GNU_SOURCE /* memmem */
#include "device_check.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fixture.h"
#include "ref_crc16.h"
#include "unity.h"
#include <avr/eeprom.h>

void setUp(void) {}
void tearDown(void) {}

/* The n-th line starting with prefix, its CRC verified; fails if absent. */
void line(const char *prefix, unsigned n, char *body, size_t size)
{
  unsigned crc;
  char msg[96];
  snprintf(msg, sizeof msg, "no line #%u starting '$%s'", n, prefix);
  TEST_ASSERT_TRUE_MESSAGE(fx_find_line(prefix, n, body, size, &crc) >= 0, msg);
  TEST_ASSERT_EQUAL_HEX16_MESSAGE(ref_crc16(body, strlen(body)), crc, body);
}

/* Every framed line in the output is whole: `$`, printable body, `*`, four
 * upper-case hex digits, CR LF, with its CRC right. */
void assert_all_lines_whole(void)
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
const char *field(const char *body, const char *key)
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
void command(const char *text)
{
  fx_send_str(text);
  fx_send_str("\r");
  fx_run_us(60000);
}

/* Offset of the first occurrence of text in the output at or after from, or -1. */
long out_find(const char *text, long from)
{
  const char *p = memmem(fx_out + from, fx_out_len - (size_t)from, text, strlen(text));
  return p ? p - fx_out : -1;
}

/* Occurrences of text in the whole output (binary frames hold NULs). */
unsigned out_count(const char *text)
{
  unsigned n = 0;
  for (long at = out_find(text, 0); at >= 0; at = out_find(text, at + 1))
    n++;
  return n;
}

/* The 8-byte record, its CRC-16/MODBUS big-endian after it, the rest of the
 * EEPROM erased (0xFF), as the firmware's `save` leaves it. */
void write_record(const uint8_t rec[8])
{
  unsigned crc = ref_crc16_modbus(rec, 8);
  memcpy(fake_eeprom, rec, 8);
  fake_eeprom[8] = (uint8_t)(crc >> 8);
  fake_eeprom[9] = (uint8_t)crc;
  memset(fake_eeprom + 10, 0xFF, sizeof fake_eeprom - 10);
}

static void dump(void)
{
  fwrite(fx_out, 1, fx_out_len, stderr);
}

int device_main(const struct device_test *tests, size_t n, int argc, char **argv)
{
  size_t i;
  if (argc < 2) { /* the list, for CMake */
    for (i = 0; i < n; i++)
      printf("%s\n", tests[i].name);
    return 0;
  }
  if (getenv("FX_DUMP"))
    atexit(dump);
  UNITY_BEGIN();
  for (i = 0; i < n; i++)
    if (strcmp(argv[1], tests[i].name) == 0)
      UnityDefaultTestRun(tests[i].fn, tests[i].name, __LINE__);
  return UNITY_END();
}
