/* Shared by the compiled Allan kernels (_ckernels.c and ck_*.c): types,
 * the 4-wide float64 vectors, and the kernels' entry points.  No Python here. */
#ifndef IMU_ALLAN_CKERNELS_H
#define IMU_ALLAN_CKERNELS_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

typedef long double ld;
typedef ptrdiff_t ssz; /* Py_ssize_t */

/* Exact integer sums of squares (integer codes whose partial sums stay below
 * 2^52): 128-bit accumulators where the compiler has them. */
#ifdef __SIZEOF_INT128__
#    define EXACT_OK 1
typedef unsigned __int128 u128;
#else
#    define EXACT_OK 0
typedef uint64_t u128; /* unused: exact mode is refused */
#endif
#define EXACT_BLOCK 0x1p52 /* a float64 block sum below this is an exact integer */

static inline u128 sq(int64_t d)
{
#if EXACT_OK
    return (u128)((__int128)d * d);
#else
    return (u128)d * (u128)d;
#endif
}

#if defined(__GNUC__) && defined(__x86_64__) && defined(__linux__) && !defined(__clang__)
#    define HOT __attribute__((target_clones("avx2", "default")))
#else
#    define HOT
#endif

#define SUMBLOCK 1024 /* float64 terms per partial sum (blocked summation) */
/* Four independent 4-wide partial sums in the inner loops, so that no add
 * waits on the previous one (GCC/clang vector extensions: AVX2 in the avx2
 * clone, pairs of SSE2 operations otherwise). */
typedef double v4 __attribute__((vector_size(32)));

static inline v4 ld4(const double *p)
{
    v4 v;
    memcpy(&v, p, sizeof v);
    return v;
}
static inline void st4(double *p, v4 v)
{
    memcpy(p, &v, sizeof v);
}
static inline double hsum(v4 a, v4 b, v4 c, v4 d)
{
    v4 s = (a + b) + (c + d);
    return (s[0] + s[1]) + (s[2] + s[3]);
}

#define MAXLEV 64   /* octave levels at most (m = 2^63) */
#define PBLOCK 1024 /* phase samples per block (any-m kernel) */

enum fmt { F64, F32, I64, I32, I16, I8, U64, U32, U16, U8, CK_FILE };

/* fmt CK_FILE: x is a struct ck_file, samples of format fmt at byte base of
 * the open file fd, read with pread (ck_load only: the octave kernels); err is
 * set when a read fails (1) or the file is short (2). */
struct ck_file {
    int fd;
    int fmt;
    int64_t base;
    int err;
};

/* ck_core.c */
void *ck_big_alloc(size_t bytes);
void ck_load(const void *x, int fmt, ssz start, ssz count, double off, double *dst);
ld ck_value(const void *x, int fmt, ssz i);
ld ck_step(const double *buf, ssz m, ssz c, ssz L, double *nxt, u128 *ex);

/* ck_octave.c: sums per level k (m = 2^k) into acc, or exactly into ex (non-NULL);
 * 0, or -1 when out of memory */
int ck_levels(ssz n);
/* Windows of the overlapping sums taken from the same pass (stream mode): for
 * each start[w], the sum over the terms i in [start[w], start[w] + size - 2m]
 * of every level, into out[k * W + w]; the running sums are noted at every
 * window's two ends (mark), so the windows cost no second pass. */
struct ck_marks {
    ssz W, size;
    const int64_t *start;
    double *out;
    ssz *pos[MAXLEV];      /* each level's 2W ends, in order */
    int32_t *slot[MAXLEV]; /* the end each is: w (a start) or W + w (an end) */
    ld *cl[MAXLEV];
    u128 *ce[MAXLEV];
    ssz next[MAXLEV];
    void *mem;
};
int ck_marks_init(struct ck_marks *mk, int levels, const int64_t *start, ssz W, ssz size, double *out);
void ck_marks_done(struct ck_marks *mk, int levels, const ld *acc, const u128 *ex);
int ck_octave_overlap(const void *x, int fmt, ssz n, double off, ssz tile, ssz split, int stream, ld *acc,
                      u128 *ex, struct ck_marks *mk);
int ck_octave_nonoverlap(const void *x, int fmt, ssz n, double off, ssz chunk, ld *acc, u128 *ex);

/* ck_phase.c: sums at each m of ms (nan where no term) into out */
int ck_any_m(const void *x, int fmt, ssz n, double off, const int64_t *ms, ssz nm, int overlapping, int exact,
             double *out);

/* Numeric text (ck_text.c). */
ssz ck_parse_rows(const char *buf, ssz len, int ncol, int maxval, uint16_t *out, ssz cap, ssz *lines);
struct ck_table {
    int delim;        /* the separator byte, or 0: runs of blanks */
    const int *which; /* per column up to the last wanted: its output row, or -1 */
    int ncols;
    int tcol;    /* the time column, or -1 */
    double *out; /* (rows of which, cap) float64 */
    ssz cap;
    int64_t *tint; /* the time column as integers and as float64 (cap each) */
    double *tflt;
    int *tfloat; /* set when a time value is not a plain integer */
};
ssz ck_parse_table(const char *buf, ssz len, const struct ck_table *t);
ssz ck_diff_look(const double *x, ssz n, double prev, int has_prev, ssz pos, ssz step, double *sub,
                 double *st);
void ck_welch_prep(const double *x, ssz nseg, ssz step, ssz k, const double *mean, const double *w,
                   double *out);
void ck_welch_prep32(const double *x, ssz nseg, ssz step, ssz k, const double *mean, const double *w,
                     float *out);
void ck_welch_acc32(const float *spec, ssz k, ssz nf, double *acc);
void ck_welch_acc(const double *spec, ssz k, ssz nf, double *acc);
ssz ck_diff_grid(const double *x, ssz n, double prev, int has_prev, double q, int gmax, int64_t *cnt);

#endif
