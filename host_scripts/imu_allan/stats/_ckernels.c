/* Compiled Allan kernels of imu_allan.stats (kernels.py keeps the numpy path
 * as the fallback when this extension is not built).
 *
 * Plain C with the buffer protocol: no numpy headers.  Every function takes a
 * C-contiguous 1-D buffer of rate samples (float64/32, int8..int64, uint8..32;
 * a numpy array or an np.memmap of a file) and the offset removed before
 * summing, and fills a float64 buffer of sums of squares, one per level.
 *
 *   octave_overlap    overlapping octave sums, the two-stage cache-blocked
 *                     cascade y_2m[i] = y_m[i] + y_m[i+m] (one buffer the size
 *                     of the input, as the numpy path); or, with stream=1, the
 *                     same first stage and, above it, one running difference
 *                     per level d_m(i+1) = d_m(i) + x[i+2m] - 2x[i+m] + x[i]
 *                     read straight from the input (O(1) memory: a file's
 *                     mmap is read in place, every level exact, no stride).
 *   octave_nonoverlap non-overlapping octave sums, pair-sum cascade in chunks.
 *   any_m             overlapping (or non-overlapping) sums at any cluster
 *                     sizes from the phase X, stored as float64 offsets from a
 *                     long double straight line per block of 1024 samples, so
 *                     that a second difference never subtracts large numbers.
 *
 * exact=1 (integer codes, partial sums below 2^52): every difference is an
 * exact integer and the sums of squares are exact 128-bit integers, rounded
 * once into the float64 result (a float64 block sum below 2^52 is taken as is,
 * a larger one recounted in integers).
 *
 * Accuracy: sums of squares are added in float64 over blocks of at most 1024
 * terms and the block sums in long double (blocked summation); cascade sums
 * are pairwise; the running differences are long double.  The results agree
 * with a long double evaluation of the definitions to ~1e-14 (tests).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

typedef long double ld;
typedef Py_ssize_t ssz;

/* Exact integer sums of squares (integer codes whose partial sums stay below
 * 2^52): 128-bit accumulators where the compiler has them. */
#ifdef __SIZEOF_INT128__
#define EXACT_OK 1
typedef unsigned __int128 u128;
#else
#define EXACT_OK 0
typedef uint64_t u128;  /* unused: exact mode is refused */
#endif
#define EXACT_BLOCK 0x1p52  /* a float64 block sum below this is an exact integer */

static inline u128 sq(int64_t d)
{
#if EXACT_OK
    return (u128)((__int128)d * d);
#else
    return (u128)d * (u128)d;
#endif
}

#if defined(__GNUC__) && defined(__x86_64__) && defined(__linux__) && !defined(__clang__)
#define HOT __attribute__((target_clones("avx2", "default")))
#else
#define HOT
#endif

#define SUMBLOCK 1024 /* float64 terms per partial sum (blocked summation) */
/* Four independent 4-wide partial sums in the inner loops, so that no add
 * waits on the previous one (GCC/clang vector extensions: AVX2 in the avx2
 * clone, pairs of SSE2 operations otherwise). */
typedef double v4 __attribute__((vector_size(32)));

static inline v4 ld4(const double *p) { v4 v; memcpy(&v, p, sizeof v); return v; }
static inline void st4(double *p, v4 v) { memcpy(p, &v, sizeof v); }
static inline double hsum(v4 a, v4 b, v4 c, v4 d)
{
    v4 s = (a + b) + (c + d);
    return (s[0] + s[1]) + (s[2] + s[3]);
}

/* A large scratch buffer: 2 MB aligned and, on Linux, backed by huge pages
 * where the kernel allows it (a fresh 80 MB buffer otherwise costs 20,000
 * page faults, as much time as the arithmetic). */
static void *big_alloc(size_t bytes)
{
    void *p = NULL;
    size_t align = (size_t)2 << 20;
    if (bytes < align) return malloc(bytes);
    bytes = (bytes + align - 1) / align * align;
    if (posix_memalign(&p, align, bytes)) return NULL;
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    madvise(p, bytes, MADV_HUGEPAGE);
#endif
    return p;
}

/* ---- input formats ------------------------------------------------------ */

enum fmt { F64, F32, I64, I32, I16, I8, U64, U32, U16, U8 };

static int parse_fmt(const Py_buffer *v)
{
    const char *f = v->format ? v->format : "B";
    while (*f == '@' || *f == '=' || *f == '<') f++;
    if (f[0] == '\0' || f[1] != '\0') return -1;
    switch (f[0]) {
    case 'd': return v->itemsize == 8 ? F64 : -1;
    case 'f': return v->itemsize == 4 ? F32 : -1;
    case 'b': return I8;
    case 'B': return U8;
    case 'h': return I16;
    case 'H': return U16;
    case 'i': case 'l': case 'q':
        return v->itemsize == 8 ? I64 : v->itemsize == 4 ? I32 : -1;
    case 'I': case 'L': case 'Q':
        return v->itemsize == 8 ? U64 : v->itemsize == 4 ? U32 : -1;
    }
    return -1;
}

/* dst[i] = x[start + i] - off as double, i < count */
static void load(const void *x, int fmt, ssz start, ssz count, double off, double *dst)
{
#define LOAD(T) do { const T *s = (const T *)x + start; \
        for (ssz i = 0; i < count; i++) dst[i] = (double)s[i] - off; } while (0)
    switch (fmt) {
    case F64: LOAD(double); break;
    case F32: LOAD(float); break;
    case I64: LOAD(int64_t); break;
    case I32: LOAD(int32_t); break;
    case I16: LOAD(int16_t); break;
    case I8: LOAD(int8_t); break;
    case U64: LOAD(uint64_t); break;
    case U32: LOAD(uint32_t); break;
    case U16: LOAD(uint16_t); break;
    case U8: LOAD(uint8_t); break;
    }
#undef LOAD
}

static ld value(const void *x, int fmt, ssz i)
{
    switch (fmt) {
    case F64: return ((const double *)x)[i];
    case F32: return ((const float *)x)[i];
    case I64: return ((const int64_t *)x)[i];
    case I32: return ((const int32_t *)x)[i];
    case I16: return ((const int16_t *)x)[i];
    case I8: return ((const int8_t *)x)[i];
    case U64: return ((const uint64_t *)x)[i];
    case U32: return ((const uint32_t *)x)[i];
    case U16: return ((const uint16_t *)x)[i];
    default: return ((const uint8_t *)x)[i];
    }
}

/* ---- inner loops ---------------------------------------------------------- */

/* sum over i < c of (buf[i+m] - buf[i])^2; and nxt[i] = buf[i] + buf[i+m] for
 * i < L (L >= c; nxt may be NULL).  One pass: the difference and the next
 * level's moving sum read the same two values. */
HOT static ld step(const double *buf, ssz m, ssz c, ssz L, double *nxt, u128 *ex)
{
    ld total = 0;
    const double *hi = buf + m;
    for (ssz s = 0; s < c; s += SUMBLOCK) {
        ssz e = s + SUMBLOCK < c ? s + SUMBLOCK : c;
        v4 a0 = {0}, a1 = {0}, a2 = {0}, a3 = {0};
        double t = 0.0;
        ssz i = s;
        if (nxt) {
            for (; i + 16 <= e; i += 16) {
                v4 x0 = ld4(buf + i), x1 = ld4(buf + i + 4), x2 = ld4(buf + i + 8), x3 = ld4(buf + i + 12);
                v4 y0 = ld4(hi + i), y1 = ld4(hi + i + 4), y2 = ld4(hi + i + 8), y3 = ld4(hi + i + 12);
                st4(nxt + i, x0 + y0); st4(nxt + i + 4, x1 + y1);
                st4(nxt + i + 8, x2 + y2); st4(nxt + i + 12, x3 + y3);
                v4 d0 = y0 - x0, d1 = y1 - x1, d2 = y2 - x2, d3 = y3 - x3;
                a0 += d0 * d0; a1 += d1 * d1; a2 += d2 * d2; a3 += d3 * d3;
            }
            for (; i < e; i++) {
                double d = hi[i] - buf[i];
                nxt[i] = buf[i] + hi[i];
                t += d * d;
            }
        } else {
            for (; i + 16 <= e; i += 16) {
                v4 d0 = ld4(hi + i) - ld4(buf + i), d1 = ld4(hi + i + 4) - ld4(buf + i + 4);
                v4 d2 = ld4(hi + i + 8) - ld4(buf + i + 8), d3 = ld4(hi + i + 12) - ld4(buf + i + 12);
                a0 += d0 * d0; a1 += d1 * d1; a2 += d2 * d2; a3 += d3 * d3;
            }
            for (; i < e; i++) {
                double d = hi[i] - buf[i];
                t += d * d;
            }
        }
        double bs = hsum(a0, a1, a2, a3) + t;
        if (!ex) {
            total += bs;
        } else if (bs < EXACT_BLOCK) {  /* every square and partial sum was an exact integer */
            *ex += (u128)(uint64_t)bs;
        } else {                        /* recount the block in integers */
            for (ssz k = s; k < e; k++) *ex += sq((int64_t)hi[k] - (int64_t)buf[k]);
        }
    }
    if (nxt)
        for (ssz i = c; i < L; i++) nxt[i] = buf[i] + hi[i];
    return total;
}

/* ---- overlapping octave sums ----------------------------------------------- */

static int levels_of(ssz n)
{
    int k = 0;
    if (n < 2) return 0;
    while (((ssz)2 << k) <= n) k++;  /* largest k with 2^k <= n/2 ... */
    return k;                        /* levels: m = 2^0 .. 2^(k-1), 2^(k-1) <= n/2 */
}

/* The running second differences of the levels K .. levels-1 (m >= 2^K):
 * d_m(i) = y_m(i+m) - y_m(i), d_m(i+1) = d_m(i) + x[i+2m] - 2 x[i+m] + x[i]
 * (the offset cancels).  Long double; all levels advance together over
 * blocks of i so that the input is read once per block per distinct offset. */
#define CHAIN_BLOCK 2048
#define MAXLEV 64

static void chains(const void *x, int fmt, ssz n, int K, int levels, ld *acc, u128 *ex)
{
    int nl = levels - K;
    if (nl <= 0) return;
    ld d[MAXLEV];
    ssz last[MAXLEV];
    for (int j = 0; j < nl; j++) {
        ssz m = (ssz)1 << (K + j);
        ld s0 = 0, s1 = 0;
        for (ssz i = 0; i < m; i++) { s0 += value(x, fmt, i); s1 += value(x, fmt, i + m); }
        d[j] = s1 - s0;
        last[j] = n - 2 * m;  /* terms i = 0 .. last */
        acc[K + j] = 0;
        if (ex) ex[K + j] = 0;
    }
    /* the offsets read: 0 and 2^K .. 2^levels; each block converted once */
    int no = nl + 3;  /* one spare: the pair loop reads offset 2^(levels+1) of a lone last level */
    double *blk = malloc(sizeof(double) * (size_t)no * CHAIN_BLOCK);
    if (!blk) return;
    ssz top = last[0];  /* the longest chain */
    for (ssz a = 0; a < top; a += CHAIN_BLOCK) {
        ssz len = a + CHAIN_BLOCK <= top ? CHAIN_BLOCK : top - a;  /* steps i = a .. a+len-1 */
        load(x, fmt, a, len, 0.0, blk);
        for (int o = 1; o < no; o++) {
            ssz off = (ssz)1 << (K + o - 1);
            ssz cnt = len;
            if (a + off + cnt > n) cnt = n - a - off;
            if (cnt > 0) load(x, fmt, a + off, cnt, 0.0, blk + (size_t)o * CHAIN_BLOCK);
        }
        if (ex) {  /* integer codes: int64 differences, 128-bit sums: exact */
            for (int j = 0; j < nl; j++) {
                ssz st = last[j] - a;
                if (st > len) st = len;
                const double *x0 = blk, *x1 = blk + (size_t)(j + 1) * CHAIN_BLOCK,
                             *x2 = blk + (size_t)(j + 2) * CHAIN_BLOCK;
                int64_t dj = (int64_t)d[j];
                u128 t = 0;
                for (ssz i = 0; i < st; i++) {
                    t += sq(dj);
                    dj += (int64_t)x2[i] + (int64_t)x0[i] - 2 * (int64_t)x1[i];
                }
                d[j] = (ld)dj;
                ex[K + j] += t;
            }
            continue;
        }
        /* two levels per loop: two independent long double chains hide the add latency */
        for (int j = 0; j < nl; j += 2) {
            int two = j + 1 < nl;
            ssz sa = last[j] - a, sb = two ? last[j + 1] - a : 0;
            if (sa > len) sa = len;
            if (sb > len) sb = len;
            if (sa < 0) sa = 0;
            if (sb < 0) sb = 0;
            const double *x0 = blk, *x1 = blk + (size_t)(j + 1) * CHAIN_BLOCK,
                         *x2 = blk + (size_t)(j + 2) * CHAIN_BLOCK,
                         *x3 = blk + (size_t)(j + 3) * CHAIN_BLOCK;
            ld da = d[j], db = two ? d[j + 1] : 0, ta = 0, tb = 0;
            ssz both = two ? (sa < sb ? sa : sb) : 0, i = 0;
            for (; i < both; i++) {
                ld u0 = x0[i], u1 = x1[i], u2 = x2[i], u3 = x3[i];
                ta += da * da;
                tb += db * db;
                da += (u2 + u0) - 2 * u1;
                db += (u3 + u0) - 2 * u2;
            }
            for (ssz k = i; k < sa; k++) {
                ta += da * da;
                da += ((ld)x2[k] + (ld)x0[k]) - 2 * (ld)x1[k];
            }
            for (ssz k = i; k < sb; k++) {
                tb += db * db;
                db += ((ld)x3[k] + (ld)x0[k]) - 2 * (ld)x2[k];
            }
            d[j] = da;
            acc[K + j] += ta;
            if (two) { d[j + 1] = db; acc[K + j + 1] += tb; }
        }
    }
    for (int j = 0; j < nl; j++) {  /* the term i = last */
        if (ex) ex[K + j] += sq((int64_t)d[j]);
        else acc[K + j] += d[j] * d[j];
    }
    free(blk);
}

static int octave_overlap_impl(const void *x, int fmt, ssz n, double off, ssz tile, ssz split,
                               int stream, ld *acc, u128 *ex)
{
    int levels = levels_of(n);
    for (int k = 0; k < levels; k++) acc[k] = 0;
    if (!levels) return 0;
    ssz M = split < ((ssz)1 << levels) ? split : ((ssz)1 << levels);
    int K = 0;
    while (((ssz)1 << (K + 1)) <= M) K++;
    ssz T = tile > 8 * M ? tile : 8 * M;
    ssz LY = n - M + 1;
    int stage2 = K < levels && !stream;
    ssz Q = (LY + M - 1) / M;
    double *Y = NULL, *b0 = NULL, *b1 = NULL;
    if (stage2) {
        Y = big_alloc(sizeof(double) * (size_t)(Q * M));
        if (!Y) return -1;
        memset(Y + LY, 0, sizeof(double) * (size_t)(Q * M - LY));
    }
    b0 = malloc(sizeof(double) * (size_t)(T + M));
    b1 = malloc(sizeof(double) * (size_t)(T + M));
    if (!b0 || !b1) { free(Y); free(b0); free(b1); return -1; }
    for (ssz a = 0; a < LY; a += T) {
        ssz b = a + T + M - 1 < n ? a + T + M - 1 : n;
        ssz L = b - a;
        int last = a + T >= LY;
        double *buf = b0, *nxt = b1;
        load(x, fmt, a, L, off, buf);
        for (int k = 0; k < K; k++) {
            ssz m = (ssz)1 << k;
            ssz c = n - 2 * m + 1 - a;
            if (!last && c > T) c = T;
            if (c <= 0) break;
            L -= m;
            acc[k] += step(buf, m, c, L, nxt, ex ? ex + k : NULL);
            double *t = buf; buf = nxt; nxt = t;
        }
        if (Y) {
            ssz cnt = T < LY - a ? T : LY - a;
            memcpy(Y + a, buf, sizeof(double) * (size_t)cnt);
        }
    }
    free(b0); free(b1);
    if (stream) {
        chains(x, fmt, n, K, levels, acc, ex);
        return 0;
    }
    if (!Y) return 0;
    /* stage 2: columns r0 .. r0+R of Y (rows of M) through every upper level */
    ssz want = tile / 2 / Q;
    if (want < 1) want = 1;
    int lb = 0;
    while (((ssz)2 << lb) <= want) lb++;
    if (lb < 3) lb = 3;
    ssz R = ((ssz)1 << lb) < M ? ((ssz)1 << lb) : M;
    double *t0 = malloc(sizeof(double) * (size_t)(Q * R)), *t1 = malloc(sizeof(double) * (size_t)(Q * R));
    if (!t0 || !t1) { free(Y); free(t0); free(t1); return -1; }
    for (ssz r0 = 0; r0 < M; r0 += R) {
        double *src = t0, *dst = t1;
        for (ssz q = 0; q < Q; q++) memcpy(src + q * R, Y + q * M + r0, sizeof(double) * (size_t)R);
        for (int k = K; k < levels; k++) {
            ssz m = (ssz)1 << k;
            ssz e0 = n - 2 * m - r0;
            if (e0 < 0) break;
            ssz qf = e0 / M, rem = e0 % M;
            ssz cnt = qf * R + (R < rem + 1 ? R : rem + 1);
            ssz s = (m / M) * R;
            acc[k] += step(src, s, cnt, cnt, dst, ex ? ex + k : NULL);
            double *t = src; src = dst; dst = t;
        }
    }
    free(t0); free(t1); free(Y);
    return 0;
}

/* ---- non-overlapping octave sums -------------------------------------------- */

/* Cluster sums cascade S_2m[j] = S_m[2j] + S_m[2j+1] inside chunks; the pair
 * across a chunk boundary uses the previous chunk's last sum (slot 0). */

static int octave_nonoverlap_impl(const void *x, int fmt, ssz n, double off, ssz chunk, ld *acc, u128 *ex)
{
    int levels = levels_of(n);
    for (int k = 0; k < levels; k++) acc[k] = 0;
    if (!levels) return 0;
    int KC = 0;
    while (((ssz)2 << KC) <= chunk) KC++;
    int inner = levels < KC + 1 ? levels : KC + 1;
    double *bufs[MAXLEV];
    int have[MAXLEV];
    double *top = malloc(sizeof(double) * (size_t)(n / chunk + 1));
    if (!top) return -1;
    for (int k = 0; k < inner; k++) {
        bufs[k] = malloc(sizeof(double) * (size_t)((chunk >> k) + 1));
        have[k] = 0;
        if (!bufs[k]) { for (int j = 0; j < k; j++) free(bufs[j]); free(top); return -1; }
    }
    ssz ntop = 0;
    for (ssz a = 0; a < n; a += chunk) {
        ssz L = a + chunk <= n ? chunk : n - a;
        load(x, fmt, a, L, off, bufs[0] + 1);
        for (int k = 0; k < inner; k++) {
            double *buf = bufs[k];
            ssz lo = have[k] ? 0 : 1;  /* slot 0: the previous chunk's last sum */
            if (L + 1 - lo >= 2) acc[k] += step(buf + lo, 1, L - lo, 0, NULL, ex ? ex + k : NULL);
            if (L >= 1) { buf[0] = buf[L]; have[k] = 1; }
            if (k + 1 < inner) {
                ssz h = L / 2;
                double *up = bufs[k + 1] + 1;
                for (ssz j = 0; j < h; j++) up[j] = buf[2 * j + 1] + buf[2 * j + 2];
                L = h;
            } else if (inner < levels && L == 1) {
                top[ntop++] = buf[1];
            }
        }
    }
    /* levels above the chunk: plain cascade over the chunk sums (in place) */
    ssz cnt = ntop;
    for (int k = inner; k < levels; k++) {
        ssz h = cnt / 2;
        for (ssz j = 0; j < h; j++) top[j] = top[2 * j] + top[2 * j + 1];
        cnt = h;
        ld s = 0;
        for (ssz j = 0; j + 1 < cnt; j++) {
            double d = top[j + 1] - top[j];
            if (ex) ex[k] += sq((int64_t)d);
            else s += (ld)d * d;
        }
        acc[k] = s;
    }
    for (int k = 0; k < inner; k++) free(bufs[k]);
    free(top);
    return 0;
}

/* ---- any cluster sizes, from the phase --------------------------------------- */

#define PBLOCK 1024  /* phase samples per block */

/* The phase X(i) = sum_{j<i} (x_j - off), i = 0 .. n, stored as
 *   X(i) = base[b] + mu[b] * (i - b PBLOCK) + rel[i],   b = i / PBLOCK,
 * base in long double, mu the block's mean rate, rel in float64: rel stays
 * small (a block's deviation from its own straight line) even for a walk or a
 * ramp far from the offset, so second differences lose no digits to it. */
struct phase { double *rel, *mu; ld *base; };

static int phase(const void *x, int fmt, ssz n, double off, int exact, struct phase *ph)
{
    ssz nb = n / PBLOCK + 1;
    ph->rel = malloc(sizeof(double) * (size_t)(n + 1));
    ph->mu = malloc(sizeof(double) * (size_t)nb);
    ph->base = malloc(sizeof(ld) * (size_t)nb);
    double tmp[PBLOCK];
    if (!ph->rel || !ph->mu || !ph->base) {
        free(ph->rel); free(ph->mu); free(ph->base);
        return -1;
    }
    ld X = 0;
    for (ssz b = 0; b < nb; b++) {
        ssz a = b * PBLOCK;
        ssz cnt = PBLOCK < n - a ? PBLOCK : n - a;  /* samples a .. a+cnt-1: points a+1 .. a+cnt */
        load(x, fmt, a, cnt, off, tmp);
        ld r = 0;
        for (ssz i = 0; i < cnt; i++) r += tmp[i];
        double mu = cnt > 0 ? (double)(r / cnt) : 0.0;
        if (exact) mu = rint(mu);  /* integer codes: an integral line keeps rel integral */
        ph->base[b] = X;
        ph->mu[b] = mu;
        ph->rel[a] = 0.0;
        r = 0;
        for (ssz i = 0; i + 1 < PBLOCK && i < cnt; i++) {
            r += (ld)tmp[i] - mu;
            ph->rel[a + i + 1] = (double)r;
        }
        for (ssz i = 0; i < cnt; i++) X += tmp[i];
    }
    return 0;
}

static inline ld phase_at(const struct phase *ph, ssz p)
{
    ssz b = p / PBLOCK;
    return ph->base[b] + (ld)ph->mu[b] * (ld)(p - b * PBLOCK) + (ld)ph->rel[p];
}

/* sum over j < cnt of (r2[j] - 2 r1[j] + r0[j] + c0 + j c1)^2 */
HOT static double seg2(const double *r0, const double *r1, const double *r2, ssz cnt, double c0, double c1)
{
    v4 a0 = {0}, a1 = {0};
    v4 c0v = {c0, c0, c0, c0}, c1v = {c1, c1, c1, c1}, j0 = {0, 1, 2, 3}, four = {4, 4, 4, 4};
    double t = 0.0;
    ssz i = 0;
    for (; i + 8 <= cnt; i += 8) {
        v4 j1 = j0 + four;
        v4 d0 = (ld4(r2 + i) - 2.0 * ld4(r1 + i) + ld4(r0 + i)) + (c0v + j0 * c1v);
        v4 d1 = (ld4(r2 + i + 4) - 2.0 * ld4(r1 + i + 4) + ld4(r0 + i + 4)) + (c0v + j1 * c1v);
        a0 += d0 * d0; a1 += d1 * d1;
        j0 = j1 + four;
    }
    for (; i < cnt; i++) {
        double d = (r2[i] - 2.0 * r1[i] + r0[i]) + (c0 + (double)i * c1);
        t += d * d;
    }
    v4 z = {0};
    return hsum(a0, a1, z, z) + t;
}

static ld overlap_m(const struct phase *ph, ssz n, ssz m, u128 *ex)
{
    ssz c = n - 2 * m + 1;  /* terms i = 0 .. c-1 */
    ld total = 0;
    for (ssz i = 0; i < c;) {
        ssz p0 = i, p1 = i + m, p2 = i + 2 * m;
        ssz b0 = p0 / PBLOCK, b1 = p1 / PBLOCK, b2 = p2 / PBLOCK;
        ssz e = c - i, r;
        if ((r = (b0 + 1) * PBLOCK - p0) < e) e = r;
        if ((r = (b1 + 1) * PBLOCK - p1) < e) e = r;
        if ((r = (b2 + 1) * PBLOCK - p2) < e) e = r;
        /* the blocks' straight lines: c0 + j c1 over the segment */
        ld c0 = ph->base[b2] + (ld)ph->mu[b2] * (ld)(p2 - b2 * PBLOCK)
                - 2 * (ph->base[b1] + (ld)ph->mu[b1] * (ld)(p1 - b1 * PBLOCK))
                + ph->base[b0] + (ld)ph->mu[b0] * (ld)(p0 - b0 * PBLOCK);
        ld c1 = (ld)ph->mu[b2] - 2 * (ld)ph->mu[b1] + (ld)ph->mu[b0];
        double bs = seg2(ph->rel + p0, ph->rel + p1, ph->rel + p2, e, (double)c0, (double)c1);
        if (!ex) total += bs;
        else if (bs < EXACT_BLOCK) *ex += (u128)(uint64_t)bs;
        else
            for (ssz j = i; j < i + e; j++)
                *ex += sq((int64_t)(phase_at(ph, j + 2 * m) - 2 * phase_at(ph, j + m) + phase_at(ph, j)));
        i += e;
    }
    return total;
}

static ld nonoverlap_m(const struct phase *ph, ssz n, ssz m, u128 *ex)
{
    ssz c = n / m - 1;
    ld total = 0;
    for (ssz j = 0; j < c; j++) {
        ssz p = j * m;
        ld d = phase_at(ph, p + 2 * m) - 2 * phase_at(ph, p + m) + phase_at(ph, p);
        if (ex) *ex += sq((int64_t)d);
        else total += d * d;
    }
    return total;
}

/* ---- Python glue -------------------------------------------------------------- */

static int get_in(PyObject *obj, Py_buffer *v, int *fmt)
{
    if (PyObject_GetBuffer(obj, v, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) return -1;
    if (v->ndim != 1 || (*fmt = parse_fmt(v)) < 0) {
        PyBuffer_Release(v);
        PyErr_SetString(PyExc_TypeError, "x: a contiguous 1-D buffer of int8..64, uint8..64, float32 or float64");
        return -1;
    }
    return 0;
}

static int get_out(PyObject *obj, Py_buffer *v, ssz need)
{
    if (PyObject_GetBuffer(obj, v, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE) < 0) return -1;
    if (v->ndim != 1 || v->itemsize != 8 || !v->format || strchr(v->format, 'd') == NULL
        || v->shape[0] < need) {
        PyBuffer_Release(v);
        PyErr_SetString(PyExc_ValueError, "out: a writable float64 buffer, one slot per level");
        return -1;
    }
    return 0;
}

static PyObject *py_octave(PyObject *args, int kind)
{
    PyObject *xo, *oo;
    double off;
    Py_ssize_t p1 = 1 << 17, p2 = 1 << 14;
    int stream = 0, exact = 0;
    if (kind == 0) {
        if (!PyArg_ParseTuple(args, "OdO|nnii", &xo, &off, &oo, &p1, &p2, &stream, &exact)) return NULL;
    } else {
        if (!PyArg_ParseTuple(args, "OdO|ni", &xo, &off, &oo, &p1, &exact)) return NULL;
    }
    if (exact && !EXACT_OK) {
        PyErr_SetString(PyExc_ValueError, "exact: no 128-bit integers in this build");
        return NULL;
    }
    if (p1 < 1 || p2 < 1 || (p1 & (p1 - 1)) || (p2 & (p2 - 1))) {
        PyErr_SetString(PyExc_ValueError, "tile, split and chunk: powers of two");
        return NULL;
    }
    Py_buffer xv, ov;
    int fmt;
    if (get_in(xo, &xv, &fmt) < 0) return NULL;
    ssz n = xv.shape[0];
    int levels = levels_of(n);
    if (get_out(oo, &ov, levels) < 0) { PyBuffer_Release(&xv); return NULL; }
    ld acc[MAXLEV];
    u128 ex[MAXLEV];
    int rc;
    memset(ex, 0, sizeof ex);
    Py_BEGIN_ALLOW_THREADS
    rc = kind == 0 ? octave_overlap_impl(xv.buf, fmt, n, off, p1, p2, stream, acc, exact ? ex : NULL)
                   : octave_nonoverlap_impl(xv.buf, fmt, n, off, p1, acc, exact ? ex : NULL);
    Py_END_ALLOW_THREADS
    for (int k = 0; k < levels; k++)  /* exact: the integer sum, rounded once */
        ((double *)ov.buf)[k] = exact ? (double)ex[k] : (double)acc[k];
    PyBuffer_Release(&xv);
    PyBuffer_Release(&ov);
    if (rc) return PyErr_NoMemory();
    return PyLong_FromLong(levels);
}

static PyObject *octave_overlap(PyObject *self, PyObject *args) { (void)self; return py_octave(args, 0); }
static PyObject *octave_nonoverlap(PyObject *self, PyObject *args) { (void)self; return py_octave(args, 1); }

static PyObject *any_m(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *xo, *mo, *oo;
    double off;
    int overlapping, exact = 0;
    if (!PyArg_ParseTuple(args, "OdOOp|i", &xo, &off, &mo, &oo, &overlapping, &exact)) return NULL;
    if (exact && !EXACT_OK) {
        PyErr_SetString(PyExc_ValueError, "exact: no 128-bit integers in this build");
        return NULL;
    }
    Py_buffer xv, mv, ov;
    int fmt;
    if (get_in(xo, &xv, &fmt) < 0) return NULL;
    if (PyObject_GetBuffer(mo, &mv, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) { PyBuffer_Release(&xv); return NULL; }
    if (mv.ndim != 1 || mv.itemsize != 8 || parse_fmt(&mv) != I64) {
        PyBuffer_Release(&xv); PyBuffer_Release(&mv);
        PyErr_SetString(PyExc_TypeError, "ms: contiguous int64");
        return NULL;
    }
    ssz nm = mv.shape[0];
    if (get_out(oo, &ov, nm) < 0) { PyBuffer_Release(&xv); PyBuffer_Release(&mv); return NULL; }
    ssz n = xv.shape[0];
    const int64_t *ms = mv.buf;
    double *out = ov.buf;
    int rc = 0;
    Py_BEGIN_ALLOW_THREADS
    struct phase ph;
    rc = phase(xv.buf, fmt, n, off, exact, &ph);
    if (!rc) {
        for (ssz j = 0; j < nm; j++) {
            ssz m = ms[j];
            ssz terms = overlapping ? n - 2 * m + 1 : (m > 0 ? n / m - 1 : 0);
            if (m < 1 || terms < 1) { out[j] = NAN; continue; }
            u128 e = 0;
            ld f = overlapping ? overlap_m(&ph, n, m, exact ? &e : NULL) : nonoverlap_m(&ph, n, m, exact ? &e : NULL);
            out[j] = exact ? (double)e : (double)f;
        }
        free(ph.rel);
        free(ph.mu);
        free(ph.base);
    }
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&xv); PyBuffer_Release(&mv); PyBuffer_Release(&ov);
    if (rc) return PyErr_NoMemory();
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"octave_overlap", octave_overlap, METH_VARARGS,
     "octave_overlap(x, off, out, tile=2**17, split=2**14, stream=0, exact=0) -> levels\n"
     "Overlapping octave sums of squares into out[k] (m = 2^k)."},
    {"octave_nonoverlap", octave_nonoverlap, METH_VARARGS,
     "octave_nonoverlap(x, off, out, chunk=2**16, exact=0) -> levels\n"
     "Non-overlapping octave sums of squares into out[k]."},
    {"any_m", any_m, METH_VARARGS,
     "any_m(x, off, ms, out, overlapping, exact=0)\n"
     "Sums of squared second differences of the phase at each m (nan where no term)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_ckernels",
                                    "Compiled Allan kernels (see kernels.py).", -1, methods,
                                    NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__ckernels(void)
{
    PyObject *m = PyModule_Create(&module);
    if (m && PyModule_AddIntConstant(m, "EXACT", EXACT_OK) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
