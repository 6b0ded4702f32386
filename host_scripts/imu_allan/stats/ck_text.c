/* Delimited numeric text to channel-major arrays, in one pass over the bytes
 * (the readers of imu_allan.sources: rows.py, table.py).  No Python here.
 *
 * ck_parse_rows: the thesis' rows (rows.py's rules): lines of ncol unsigned
 *   decimal integers separated by blanks (space, tab, VT, FF, CR); '#' starts
 *   a comment to the end of the line; a line starting with '$' (a protocol
 *   line of a raw capture) is skipped whole; a line with no number is skipped.
 *   Any other byte, a line with another count of numbers, a number of more
 *   than 9 digits or above ``maxval`` is a fault: the caller's exact reader
 *   then names the line.
 *
 * ck_parse_table: delimited numbers (a CSV's data rows, after its header):
 *   fields separated by ``delim`` (or runs of blanks when delim is 0), blanks
 *   around a field ignored; the wanted columns parsed as decimal numbers
 *   (strtod's syntax without hex, inf or nan: sign, digits, '.', exponent),
 *   the others skipped unread.  A plain integer of up to 18 digits is
 *   converted exactly; any other number by strtod, which is correctly
 *   rounded (glibc), as pandas' round-trip parser and Python's float() are.
 *   Blank lines and lines whose first non-blank byte is '#' are skipped; a
 *   row with fewer fields than the last wanted column, or a wanted field that
 *   is not a number, is a fault (the caller's reader names it).
 */
#include <stdint.h>
#include <stdlib.h>

#include "ckernels.h"

static inline int is_blank(unsigned char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

ssz ck_parse_rows(const char *buf, ssz len, int ncol, int maxval, uint16_t *out, ssz cap, ssz *lines)
{
    const unsigned char *p = (const unsigned char *)buf, *end = p + len;
    ssz row = 0, ends = 0;
    while (p < end) {
        /* one line */
        if (*p == '$') {
            while (p < end && *p != '\n') p++;
            ends += p < end;
            p += p < end;
            continue;
        }
        int col = 0;
        while (p < end && *p != '\n') {
            unsigned c = *p;
            if (c - '0' < 10u) {
                const unsigned char *start = p;
                uint32_t v = 0;
                while (p < end && (unsigned)(*p - '0') < 10u) v = v * 10 + (*p++ - '0');
                if (p - start > 9 || v > (uint32_t)maxval || col >= ncol || row >= cap) return -1;
                out[(ssz)col * cap + row] = (uint16_t)v;
                col++;
            } else if (is_blank((unsigned char)c)) {
                p++;
            } else if (c == '#') {
                while (p < end && *p != '\n') p++;
            } else {
                return -1;
            }
        }
        ends += p < end;
        p += p < end;
        if (col == ncol)
            row++;
        else if (col)
            return -1;
    }
    *lines = ends;
    return row;
}

/* A field's blanks: space and tab (pandas' own; other control bytes are data). */
static inline int is_sp(unsigned char c)
{
    return c == ' ' || c == '\t';
}

static const double P10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                             1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

/* The number of the field [p, end), blanks around it skipped, in one pass:
 * 1 when it is a plain integer (*i and *v set; |value| <= INT64_MAX), 0 when
 * another decimal number (*v set), -1 when not a number (strtod's syntax
 * without hex, inf or nan: sign, digits, '.', exponent).
 * A decimal of at most 19 significant digits whose integer mantissa M is at
 * most 2^53 and whose power of ten 10^e has |e| <= 22 is Clinger's exact
 * case: M and 10^e are exact doubles, so M * 10^e or M / 10^-e, one IEEE
 * operation, is the correctly rounded value; any other goes to strtod
 * (correctly rounded in glibc), as pandas' and Python's parsers round. */
static int number(const unsigned char *p, const unsigned char *end, double *v, int64_t *i)
{
    while (p < end && is_sp(*p)) p++;
    while (end > p && is_sp(end[-1])) end--;
    const unsigned char *start = p;
    int neg = 0;
    if (p < end && (*p == '+' || *p == '-')) neg = *p++ == '-';
    uint64_t m = 0;
    int sig = 0, e = 0, digits = 0, point = 0, expo = 0;
    for (; p < end; p++) {
        unsigned c = (unsigned)(*p - '0');
        if (c < 10u) {
            digits++;
            if (m || c) {
                if (++sig <= 19)
                    m = m * 10 + c;
                else if (!point)
                    e++; /* a digit past 19: only its place counts (inexact: strtod) */
            }
            e -= point && sig <= 19;
        } else if (*p == '.' && !point) {
            point = 1;
        } else {
            break;
        }
    }
    if (!digits) return -1;
    if (p < end) { /* the exponent */
        if (*p != 'e' && *p != 'E') return -1;
        p++;
        int eneg = p < end && *p == '-', x = 0;
        p += p < end && (*p == '+' || *p == '-');
        if (p == end) return -1;
        for (; p < end; p++) {
            if ((unsigned)(*p - '0') >= 10u) return -1;
            if (x < 100000) x = x * 10 + (*p - '0');
        }
        e += eneg ? -x : x;
        expo = 1;
    }
    if (!point && !expo && sig <= 19 && m <= (uint64_t)INT64_MAX) { /* a plain integer */
        *i = neg ? -(int64_t)m : (int64_t)m;
        *v = neg ? -(double)m : (double)m; /* correctly rounded, as strtod; "-0" is -0.0 */
        return 1;
    }
    if (sig <= 19 && m <= ((uint64_t)1 << 53) && (m == 0 || (e >= -22 && e <= 22))) {
        double r = m == 0 ? 0.0 : e < 0 ? (double)m / P10[-e] : (double)m * P10[e];
        *v = neg ? -r : r;
        return 0;
    }
    char tmp[128], *s = tmp, *stop;
    ssz k = end - start;
    if (k >= (ssz)sizeof tmp && !(s = malloc((size_t)k + 1))) return -1;
    memcpy(s, start, (size_t)k);
    s[k] = '\0';
    *v = strtod(s, &stop);
    int ok = stop == s + k;
    if (s != tmp) free(s);
    return ok ? 0 : -1;
}

/* One line's content [p, ce) split into fields: the wanted ones parsed into
 * row ``row``.  Returns the count of fields, or -1. */
static int table_line(const unsigned char *p, const unsigned char *ce, const struct ck_table *t, ssz row)
{
    int col = 0;
    if (!t->delim)
        while (p < ce && is_sp(*p)) p++;
    for (;;) {
        const unsigned char *f = p;
        if (t->delim) {
            while (p < ce && *p != t->delim && *p != '"' && *p != '\r') p++;
        } else {
            while (p < ce && !is_sp(*p) && *p != '"' && *p != '\r') p++;
        }
        if (p < ce && (*p == '"' || *p == '\r')) return -1; /* quoting, a lone CR: pandas' */
        if (col < t->ncols && (t->which[col] >= 0 || col == t->tcol)) {
            double v;
            int64_t i = 0;
            int kind = number(f, p, &v, &i);
            if (kind < 0) return -1;
            if (col == t->tcol) {
                t->tint[row] = i;
                t->tflt[row] = v;
                t->tfloat[0] |= kind == 0;
            } else {
                t->out[(ssz)t->which[col] * t->cap + row] = v;
            }
        }
        col++;
        if (!t->delim)
            while (p < ce && is_sp(*p)) p++;
        if (p >= ce) return col;
        if (t->delim) p++; /* past the delimiter: a field follows, maybe empty */
    }
}

/* Rows of delimited numbers (t): the rows, or -(1 + the index of the first line
 * that is not plainly such a row; line 0: the buffer's first). */
ssz ck_parse_table(const char *buf, ssz len, const struct ck_table *t)
{
    const unsigned char *p = (const unsigned char *)buf, *end = p + len;
    ssz row = 0, line = 0;
    int fields = -1;
    for (; p < end; line++) {
        const unsigned char *eol = memchr(p, '\n', (size_t)(end - p));
        if (!eol) eol = end;
        const unsigned char *ce = memchr(p, '#', (size_t)(eol - p)); /* a comment ends the row */
        if (!ce) {
            ce = eol;
            if (ce > p && ce[-1] == '\r') ce--; /* CR LF */
        }
        if (ce == p) { /* an empty or comment line: skipped */
            p = eol + 1;
            continue;
        }
        if (row >= t->cap) return -(1 + line);
        int nf = table_line(p, ce, t, row);
        if (nf < 0 || nf < t->ncols || (fields >= 0 && nf != fields)) return -(1 + line);
        fields = nf;
        row++;
        p = eol + 1;
    }
    return row;
}

/* ---- the outlier scan's passes over first differences ------------------------ */

/* d[i] = x[i] - x[i-1] over one piece of a channel (x[-1] = *prev when
 * has_prev): every d at a global index pos + i that is a multiple of step into
 * sub (returns how many), and st[0..2] updated with the smallest nonzero |d|,
 * the largest and the smallest d; st[3] set when a d is not finite (the
 * caller's numpy pass then decides). */
ssz ck_diff_look(const double *x, ssz n, double prev, int has_prev, ssz pos, ssz step, double *sub,
                 double *st)
{
    ssz k = 0, i0 = has_prev ? 0 : 1;
    double nz = st[0], hi = st[1], lo = st[2];
    ssz g = pos - i0;                   /* the global index of d at i: g + i */
    ssz r = (g + i0) % step;            /* g + i0 >= 0: the first difference's global index */
    ssz take = i0 + (r ? step - r : 0); /* the next i whose global index is a multiple of step */
    for (ssz i = i0; i < n; i++) {
        double d = x[i] - (i ? x[i - 1] : prev);
        if (!isfinite(d)) st[3] = 1;
        double a = fabs(d);
        if (d != 0 && a < nz) nz = a;
        if (d > hi) hi = d;
        if (d < lo) lo = d;
        if (i == take) {
            sub[k++] = d;
            take += step;
        }
    }
    st[0] = nz;
    st[1] = hi;
    st[2] = lo;
    return k;
}

/* One pass of ck_diff_grid; inlined twice, so that codes (q == 1: d / 1 is d) pay no
 * division per difference. */
static inline ssz diff_grid_pass(const double *x, ssz n, double prev, int has_prev, double q, int gmax,
                                 int64_t *cnt, int divide)
{
    ssz bad = 0;
    for (ssz i = has_prev ? 0 : 1; i < n; i++) {
        double d = x[i] - (i ? x[i - 1] : prev);
        double r = rint(divide ? d / q : d);
        if (r != r) {
            bad++;
            continue;
        }
        r = r < -gmax ? -gmax : r > gmax ? gmax : r;
        cnt[(ssz)r + gmax]++;
    }
    return bad;
}

/* The counts of rint(d / q) clipped to +-gmax, at index k + gmax; returns the
 * differences left out as not numbers (the caller's numpy pass then decides). */
ssz ck_diff_grid(const double *x, ssz n, double prev, int has_prev, double q, int gmax, int64_t *cnt)
{
    return q == 1.0 ? diff_grid_pass(x, n, prev, has_prev, 1.0, gmax, cnt, 0) :
                      diff_grid_pass(x, n, prev, has_prev, q, gmax, cnt, 1);
}

/* ---- Welch's segments (psd.py) ------------------------------------------------- */

/* out[s][i] = (x[s step + i] - mean[s]) * w[i], s < k, i < nseg: numpy's
 * (seg - mean) * window, the same two roundings, in one pass. */
void ck_welch_prep(const double *x, ssz nseg, ssz step, ssz k, const double *mean, const double *w,
                   double *out)
{
    for (ssz s = 0; s < k; s++) {
        const double *src = x + s * step;
        double *dst = out + s * nseg, m = mean[s];
        for (ssz i = 0; i < nseg; i++) dst[i] = (src[i] - m) * w[i];
    }
}

/* The same, rounded once more to float32 (numpy's astype(float32) of it). */
void ck_welch_prep32(const double *x, ssz nseg, ssz step, ssz k, const double *mean, const double *w,
                     float *out)
{
    for (ssz s = 0; s < k; s++) {
        const double *src = x + s * step;
        float *dst = out + s * nseg;
        double m = mean[s];
        for (ssz i = 0; i < nseg; i++) dst[i] = (float)((src[i] - m) * w[i]);
    }
}

/* acc[f] += re^2 + im^2 of each of k spectra of nf bins (re, im interleaved),
 * in segment order: numpy's (re * re + im * im), added one segment at a time. */
void ck_welch_acc(const double *spec, ssz k, ssz nf, double *acc)
{
    for (ssz s = 0; s < k; s++) {
        const double *z = spec + 2 * s * nf;
        for (ssz f = 0; f < nf; f++) {
            double re = z[2 * f] * z[2 * f], im = z[2 * f + 1] * z[2 * f + 1];
            acc[f] += re + im;
        }
    }
}

/* The same of float32 spectra, each part widened to float64 before squaring. */
void ck_welch_acc32(const float *spec, ssz k, ssz nf, double *acc)
{
    for (ssz s = 0; s < k; s++) {
        const float *z = spec + 2 * s * nf;
        for (ssz f = 0; f < nf; f++) {
            double a = z[2 * f], b = z[2 * f + 1];
            double re = a * a, im = b * b;
            acc[f] += re + im;
        }
    }
}
