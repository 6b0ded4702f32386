/*
 * device_check.h - the native device tests' shared checks (device_check.c).
 */
#ifndef DEVICE_CHECK_H
#define DEVICE_CHECK_H

#include <stddef.h>
#include <stdint.h>

/* The n-th line starting with prefix, its CRC verified; fails if absent. */
void line(const char *prefix, unsigned n, char *body, size_t size);
/* Every framed line in the output is whole, its CRC right. */
void assert_all_lines_whole(void);
/* The value of key in a `k=v,k=v` or `k=v k=v` body, as a string. */
const char *field(const char *body, const char *key);
/* One command line, then time for its reply. */
void command(const char *text);
/* Offset of the first occurrence of text in the output at or after from, or -1. */
long out_find(const char *text, long from);
/* Occurrences of text in the whole output (binary frames hold NULs). */
unsigned out_count(const char *text);
/* A saved-settings record as `save` writes it (CRC after it, the rest erased). */
void write_record(const uint8_t rec[8]);

struct device_test {
  const char *name;
  void (*fn)(void);
};
/* Lists the tests (no argument) or runs the one named by argv[1]. */
int device_main(const struct device_test *tests, size_t n, int argc, char **argv);

/* A row of a test file's table (CMake reads the rows to name the ctests). */
#define DEVICE_TEST(f)                                                                                       \
  {                                                                                                          \
#    f, f                                                                                                    \
  }
/* The test file's main(): its table listed or one test run. */
#define DEVICE_MAIN(table)                                                                                   \
  int main(int argc, char **argv)                                                                            \
  {                                                                                                          \
    return device_main(table, sizeof table / sizeof table[0], argc, argv);                                   \
  }

#endif /* DEVICE_CHECK_H */
