/*
 * sim_rows.h - imu-sim's readers for its two input files: ADC rows (the
 * thesis format) and timed UART input.  Both report a malformed line as
 * "NAME:LINE: reason" in a caller buffer.
 */
#ifndef SIM_ROWS_H
#define SIM_ROWS_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#define ROW_COLUMNS 7
#define ROW_CODE_MAX 1023

/* A stream of ADC rows: 7 integer codes 0..1023 per line, separated by
 * tabs or spaces; blank lines, '#' comments (whole line or trailing) and
 * lines starting with '$' (protocol lines in a raw capture of the device:
 * count lines, replies) are skipped. */
typedef struct {
  const char *name; /* for messages: the path, or "stdin" */
  FILE *f;
  unsigned long line; /* line number of the last line read */
  char *buf;
  size_t cap;
} rows_t;

/* Open PATH ("-" = stdin) and validate every row before anything is
 * simulated.  A file that cannot be rewound (stdin, a pipe) is copied to
 * an anonymous temporary file on the way.  On success returns 0, the row
 * count in *nrows, and leaves the stream at the first row.  On failure
 * returns -1 with one line (without "imu-sim: ") in err. */
int rows_open(rows_t *r, const char *path, uint64_t *nrows, char *err,
              size_t errlen);

/* Next row into code[]: 1 row, 0 end of file, -1 error (message in err). */
int rows_next(rows_t *r, uint16_t code[ROW_COLUMNS], char *err, size_t errlen);

/* Back to the first row (after rows_open: the file is rewindable); 0, or
 * -1 with err set. */
int rows_rewind(rows_t *r, char *err, size_t errlen);

void rows_close(rows_t *r);

/* Timed UART input: lines "<sample_index><TAB><text>", text with C
 * escapes \r \n \t \\ \xNN (also \0 \" \').  Loaded whole (these files are
 * short); indexes must not decrease. */
typedef struct {
  uint64_t index; /* send when this many rows have been consumed */
  uint8_t *bytes;
  size_t len;
  unsigned long line;
} uart_in_t;

/* Returns the number of entries (>= 0) in *out, or -1 with err set. */
long uart_in_load(const char *path, uart_in_t **out, char *err, size_t errlen);
void uart_in_free(uart_in_t *v, long n);

#endif /* SIM_ROWS_H */
