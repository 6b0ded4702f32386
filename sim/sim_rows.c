/*
 * sim_rows.c - imu-sim's input readers (see sim_rows.h).
 */
#define _GNU_SOURCE
#include "sim_rows.h"
#include "sim_err.h"

#include <ctype.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Strip the line ending and a trailing comment; 1 if anything but blanks
 * is left.  A line starting with '$' is a protocol line (a raw capture of
 * the device holds count lines "$C,<rows>,<drops>*CRC" and replies):
 * skipped, and so is the echo of a typed command line ("> ..."). */
static int strip(char *s)
{
  if (s[0] == '$' || s[0] == '>')
    return 0;
  char *p = strchr(s, '#');
  if (p)
    *p = 0;
  for (p = s; *p; p++)
    if (!isspace((unsigned char)*p))
      return 1;
  return 0;
}

/* One non-blank line into code[]: 0 or -1 with err "NAME:LINE: ...". */
static int parse_row(rows_t *r, char *s, uint16_t code[ROW_COLUMNS], char *err,
                     size_t errlen)
{
  char *tok[ROW_COLUMNS];
  int n = 0;
  char *save = NULL;
  for (char *t = strtok_r(s, " \t\r\n\v\f", &save); t;
       t = strtok_r(NULL, " \t\r\n\v\f", &save)) {
    if (n < ROW_COLUMNS)
      tok[n] = t;
    n++;
  }
  if (n != ROW_COLUMNS) {
    err_set(err, errlen, "%s:%lu: expected %d columns, got %d", r->name,
            r->line, ROW_COLUMNS, n);
    return -1;
  }
  for (int i = 0; i < ROW_COLUMNS; i++) {
    char *end;
    errno = 0;
    long v = strtol(tok[i], &end, 10);
    if (*end || end == tok[i] || errno) {
      err_set(err, errlen, "%s:%lu: column %d: '%.20s' is not an integer",
              r->name, r->line, i + 1, tok[i]);
      return -1;
    }
    if (v < 0 || v > ROW_CODE_MAX) {
      err_set(err, errlen, "%s:%lu: column %d: %ld is outside 0..%d", r->name,
              r->line, i + 1, v, ROW_CODE_MAX);
      return -1;
    }
    code[i] = (uint16_t)v;
  }
  return 0;
}

int rows_next(rows_t *r, uint16_t code[ROW_COLUMNS], char *err, size_t errlen)
{
  for (;;) {
    ssize_t len = getline(&r->buf, &r->cap, r->f);
    if (len < 0) {
      if (ferror(r->f)) {
        err_set(err, errlen, "%s: read error: %s", r->name, strerror(errno));
        return -1;
      }
      return 0;
    }
    r->line++;
    if (!strip(r->buf))
      continue;
    return parse_row(r, r->buf, code, err, errlen) ? -1 : 1;
  }
}

int rows_open(rows_t *r, const char *path, uint64_t *nrows, char *err,
              size_t errlen)
{
  struct stat st;
  memset(r, 0, sizeof *r);
  if (!strcmp(path, "-")) {
    r->name = "stdin";
    r->f = stdin;
  } else {
    r->name = path;
    r->f = fopen(path, "r");
    if (!r->f) {
      err_set(err, errlen, "%s: %s", path, strerror(errno));
      return -1;
    }
  }
  /* Two passes need a rewindable file: spool anything else. */
  if (fstat(fileno(r->f), &st) || !S_ISREG(st.st_mode)) {
    FILE *tmp = tmpfile();
    char chunk[65536];
    size_t n;
    if (!tmp) {
      err_set(err, errlen, "%s: cannot create a temporary file: %s", r->name,
              strerror(errno));
      return -1;
    }
    while ((n = fread(chunk, 1, sizeof chunk, r->f)) > 0)
      if (fwrite(chunk, 1, n, tmp) != n) {
        err_set(err, errlen, "%s: cannot spool to a temporary file: %s",
                r->name, strerror(errno));
        fclose(tmp);
        return -1;
      }
    if (ferror(r->f)) {
      err_set(err, errlen, "%s: read error: %s", r->name, strerror(errno));
      fclose(tmp);
      return -1;
    }
    if (r->f != stdin)
      fclose(r->f);
    r->f = tmp;
    rewind(r->f);
  }

  uint16_t code[ROW_COLUMNS];
  uint64_t n = 0;
  int got;
  while ((got = rows_next(r, code, err, errlen)) > 0)
    n++;
  if (got < 0)
    return -1;
  if (!n) {
    err_set(err, errlen, "%s: no data rows", r->name);
    return -1;
  }
  rewind(r->f);
  r->line = 0;
  *nrows = n;
  return 0;
}

int rows_rewind(rows_t *r, char *err, size_t errlen)
{
  if (fseek(r->f, 0, SEEK_SET)) {
    err_set(err, errlen, "%s: cannot rewind: %s", r->name, strerror(errno));
    return -1;
  }
  clearerr(r->f);
  r->line = 0;
  return 0;
}

void rows_close(rows_t *r)
{
  if (r->f && r->f != stdin)
    fclose(r->f);
  free(r->buf);
  memset(r, 0, sizeof *r);
}

static int hexval(int c)
{
  if (c >= '0' && c <= '9')
    return c - '0';
  if (c >= 'a' && c <= 'f')
    return c - 'a' + 10;
  if (c >= 'A' && c <= 'F')
    return c - 'A' + 10;
  return -1;
}

/* The text of a timed-input line with its escapes decoded, into a new
 * buffer (length in *len); NULL with err set on a bad escape. */
static uint8_t *unescape(const char *p, size_t *len, const char *name,
                         unsigned long line, char *err, size_t errlen)
{
  uint8_t *b = malloc(strlen(p) + 1);
  size_t k = 0;
  if (!b) {
    err_set(err, errlen, "%s: out of memory", name);
    return NULL;
  }
  while (*p) {
    if (*p != '\\') {
      b[k++] = (uint8_t)*p++;
      continue;
    }
    p++;
    switch (*p) {
    case 'r':
      b[k++] = '\r';
      p++;
      break;
    case 'n':
      b[k++] = '\n';
      p++;
      break;
    case 't':
      b[k++] = '\t';
      p++;
      break;
    case '0':
      b[k++] = 0;
      p++;
      break;
    case '\\':
    case '"':
    case '\'': b[k++] = (uint8_t)*p++; break;
    case 'x': {
      int h1 = hexval(p[1]), h2 = h1 < 0 ? -1 : hexval(p[2]);
      if (h1 < 0) {
        free(b);
        err_set(err, errlen, "%s:%lu: \\x needs hex digits", name, line);
        return NULL;
      }
      if (h2 < 0) {
        b[k++] = (uint8_t)h1;
        p += 2;
      } else {
        b[k++] = (uint8_t)(h1 * 16 + h2);
        p += 3;
      }
      break;
    }
    default:
      free(b);
      if (*p)
        err_set(err, errlen,
                "%s:%lu: unknown escape '\\%c' (use \\r \\n "
                "\\t \\\\ \\xNN)",
                name, line, *p);
      else
        err_set(err, errlen, "%s:%lu: line ends with a lone '\\'", name, line);
      return NULL;
    }
  }
  *len = k;
  return b;
}

long uart_in_load(const char *path, uart_in_t **out, char *err, size_t errlen)
{
  FILE *f = strcmp(path, "-") ? fopen(path, "r") : stdin;
  const char *name = strcmp(path, "-") ? path : "stdin";
  uart_in_t *v = NULL;
  long n = 0, cap = 0;
  char *buf = NULL;
  size_t bcap = 0;
  ssize_t len;
  unsigned long line = 0;

  if (!f) {
    err_set(err, errlen, "%s: %s", path, strerror(errno));
    return -1;
  }
  while ((len = getline(&buf, &bcap, f)) >= 0) {
    line++;
    while (len > 0 && (buf[len - 1] == '\n' || buf[len - 1] == '\r'))
      buf[--len] = 0;
    if (!len || buf[0] == '#')
      continue;
    char *p = buf;
    uint64_t idx = 0;
    if (!isdigit((unsigned char)*p))
      goto bad_format;
    while (isdigit((unsigned char)*p)) {
      if (idx > (UINT64_MAX - 9) / 10)
        goto bad_format;
      idx = idx * 10 + (uint64_t)(*p++ - '0');
    }
    if (*p++ != '\t')
      goto bad_format;
    if (n && idx < v[n - 1].index) {
      err_set(err, errlen,
              "%s:%lu: sample index %llu is below the previous "
              "line's %llu (lines must be in time order)",
              name, line, (unsigned long long)idx,
              (unsigned long long)v[n - 1].index);
      goto error;
    }
    if (n == cap) {
      cap = cap ? 2 * cap : 16;
      v = realloc(v, (size_t)cap * sizeof *v);
      if (!v) {
        err_set(err, errlen, "%s: out of memory", name);
        goto error;
      }
    }
    size_t k;
    uint8_t *b = unescape(p, &k, name, line, err, errlen);
    if (!b)
      goto error;
    v[n].index = idx;
    v[n].bytes = b;
    v[n].len = k;
    v[n].line = line;
    n++;
    continue;
  bad_format:
    err_set(err, errlen, "%s:%lu: expected <sample_index><TAB><text>", name,
            line);
    goto error;
  }
  if (ferror(f)) {
    err_set(err, errlen, "%s: read error: %s", name, strerror(errno));
    goto error;
  }
  if (f != stdin)
    fclose(f);
  free(buf);
  *out = v;
  return n;
error:
  if (f != stdin)
    fclose(f);
  free(buf);
  uart_in_free(v, n);
  return -1;
}

void uart_in_free(uart_in_t *v, long n)
{
  for (long i = 0; i < n; i++)
    free(v[i].bytes);
  free(v);
}
