/* Octave Allan sums (m = 1, 2, 4 ...): the overlapping cascade in two
 * cache-blocked stages or, for a file's mapping, tiles plus running second
 * differences; the non-overlapping pair-sum cascade in chunks. */
#include <stdlib.h>

#include "ckernels.h"

/* ---- overlapping octave sums ----------------------------------------------- */

int ck_levels(ssz n)
{
    int k = 0;
    if (n < 2) return 0;
    while (((ssz)2 << k) <= n) k++; /* largest k with 2^k <= n/2 ... */
    return k;                       /* levels: m = 2^0 .. 2^(k-1), 2^(k-1) <= n/2 */
}

/* ---- window marks ------------------------------------------------------------ */

int ck_marks_init(struct ck_marks *mk, int levels, const int64_t *start, ssz W, ssz size, double *out)
{
    size_t per = (size_t)(2 * W);
    size_t bytes = (size_t)levels * per * (sizeof(ssz) + sizeof(int32_t) + sizeof(ld) + sizeof(u128));
    char *p = malloc(bytes ? bytes : 1);
    if (!p) return -1;
    mk->W = W;
    mk->size = size;
    mk->start = start;
    mk->out = out;
    mk->mem = p;
    for (int k = 0; k < levels; k++) { /* by type, the widest first: each array aligned */
        size_t at = (size_t)k * per, all = (size_t)levels * per;
        mk->ce[k] = (u128 *)p + at;
        mk->cl[k] = (ld *)(p + all * sizeof(u128)) + at;
        mk->pos[k] = (ssz *)(p + all * (sizeof(u128) + sizeof(ld))) + at;
        mk->slot[k] = (int32_t *)(p + all * (sizeof(u128) + sizeof(ld) + sizeof(ssz))) + at;
        ssz m = (ssz)1 << k;
        for (ssz w = 0; w < W; w++) { /* terms start[w] .. start[w] + size - 2m: ends s, e (e >= s) */
            ssz e = (ssz)start[w] + size - 2 * m + 1;
            mk->pos[k][w] = (ssz)start[w];
            mk->pos[k][W + w] = e > (ssz)start[w] ? e : (ssz)start[w];
        }
        for (ssz j = 0; j < 2 * W; j++) mk->slot[k][j] = (int32_t)j;
        /* insertion sort of the slots by position (2W is small) */
        for (ssz j = 1; j < 2 * W; j++) {
            int32_t v = mk->slot[k][j];
            ssz i = j;
            while (i > 0 && mk->pos[k][mk->slot[k][i - 1]] > mk->pos[k][v]) {
                mk->slot[k][i] = mk->slot[k][i - 1];
                i--;
            }
            mk->slot[k][i] = v;
        }
        mk->next[k] = 0;
    }
    return 0;
}

/* The running sums of level k are the terms i < upto: noted at the ends <= upto. */
static void mark(struct ck_marks *mk, int k, ssz upto, ld acc, u128 ex)
{
    if (!mk) return;
    while (mk->next[k] < 2 * mk->W) {
        int32_t j = mk->slot[k][mk->next[k]];
        if (mk->pos[k][j] > upto) return;
        mk->cl[k][j] = acc;
        mk->ce[k][j] = ex;
        mk->next[k]++;
    }
}

/* The next end of level k not yet noted (a position past every term if none). */
static ssz mark_next(const struct ck_marks *mk, int k)
{
    if (!mk || mk->next[k] >= 2 * mk->W) return (ssz)1 << 62;
    return mk->pos[k][mk->slot[k][mk->next[k]]];
}

void ck_marks_done(struct ck_marks *mk, int levels, const ld *acc, const u128 *ex)
{
    for (int k = 0; k < levels; k++) {
        mark(mk, k, (ssz)1 << 62, acc[k], ex ? ex[k] : 0);
        for (ssz w = 0; w < mk->W; w++) {
            ssz a = w, b = mk->W + w;
            mk->out[(ssz)k * mk->W + w] =
                ex ? (double)(mk->ce[k][b] - mk->ce[k][a]) : (double)(mk->cl[k][b] - mk->cl[k][a]);
        }
    }
    free(mk->mem);
    mk->mem = NULL;
}

/* The running second differences of the levels K .. levels-1 (m >= 2^K):
 * d_m(i) = y_m(i+m) - y_m(i), d_m(i+1) = d_m(i) + x[i+2m] - 2 x[i+m] + x[i]
 * (the offset cancels).  Long double; all levels advance together over
 * blocks of i so that the input is read once per block per distinct offset
 * (8192: a file's pread calls per level are a quarter of 2048's, 15 % less time
 * on a spilled channel; the blocks of ~12 offsets still fit in L2). */
#define CHAIN_BLOCK 8192

static void chains(const void *x, int fmt, ssz n, int K, int levels, ld *acc, u128 *ex, struct ck_marks *mk)
{
    int nl = levels - K;
    if (nl <= 0) return;
    ld d[MAXLEV];
    ssz last[MAXLEV];
    double *blk = malloc(sizeof(double) * (size_t)(nl + 3) * CHAIN_BLOCK);
    if (!blk) return;
    for (int j = 0; j < nl; j++) { /* d_m(0): the sums of x[m, 2m) and x[0, m) */
        ssz m = (ssz)1 << (K + j);
        ld s0 = 0, s1 = 0;
        for (ssz a = 0; a < 2 * m; a += CHAIN_BLOCK) {
            ssz len = a + CHAIN_BLOCK <= 2 * m ? CHAIN_BLOCK : 2 * m - a;
            ck_load(x, fmt, a, len, 0.0, blk);
            for (ssz i = 0; i < len; i++) {
                if (a + i < m)
                    s0 += blk[i];
                else
                    s1 += blk[i];
            }
        }
        d[j] = s1 - s0;
        last[j] = n - 2 * m; /* terms i = 0 .. last */
        acc[K + j] = 0;
        if (ex) ex[K + j] = 0;
    }
    /* the offsets read: 0 and 2^K .. 2^levels; each block converted once */
    int no = nl + 3;   /* one spare: the pair loop reads offset 2^(levels+1) of a lone last level */
    ssz top = last[0]; /* the longest chain */
    for (ssz a = 0, len; a < top; a += len) {
        len = a + CHAIN_BLOCK <= top ? CHAIN_BLOCK : top - a; /* steps i = a .. a+len-1 */
        for (int j = 0; mk && j < nl; j++) {                  /* a block ends at every window's end */
            mark(mk, K + j, a < last[j] ? a : last[j], acc[K + j], ex ? ex[K + j] : 0);
            ssz p = mark_next(mk, K + j);
            if (p > a && p < a + len) len = p - a;
        }
        ck_load(x, fmt, a, len, 0.0, blk);
        for (int o = 1; o < no; o++) {
            ssz off = (ssz)1 << (K + o - 1);
            ssz cnt = len;
            if (a + off + cnt > n) cnt = n - a - off;
            if (cnt > 0) ck_load(x, fmt, a + off, cnt, 0.0, blk + (size_t)o * CHAIN_BLOCK);
        }
        if (ex) { /* integer codes: int64 differences, 128-bit sums: exact */
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
                         *x2 = blk + (size_t)(j + 2) * CHAIN_BLOCK, *x3 = blk + (size_t)(j + 3) * CHAIN_BLOCK;
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
            if (two) {
                d[j + 1] = db;
                acc[K + j + 1] += tb;
            }
        }
    }
    for (int j = 0; j < nl; j++) { /* the term i = last */
        mark(mk, K + j, last[j], acc[K + j], ex ? ex[K + j] : 0);
        if (ex)
            ex[K + j] += sq((int64_t)d[j]);
        else
            acc[K + j] += d[j] * d[j];
    }
    free(blk);
}

/* Level k's step over the tile's terms a .. a+c-1 (ck_step), cut at the window ends inside. */
static ld step_marked(const double *buf, ssz m, ssz c, ssz L, double *dst, u128 *ex, struct ck_marks *mk,
                      int k, ssz a, ld acc)
{
    if (!mk) return acc + ck_step(buf, m, c, L, dst, ex);
    for (ssz s = 0, e; s < c; s = e) {
        mark(mk, k, a + s, acc, ex ? *ex : 0);
        ssz p = mark_next(mk, k) - a;
        e = p > s && p < c ? p : c;
        acc += ck_step(buf + s, m, e - s, (e == c ? L : e) - s, dst ? dst + s : NULL, ex);
    }
    mark(mk, k, a + c, acc, ex ? *ex : 0);
    return acc;
}

int ck_octave_overlap(const void *x, int fmt, ssz n, double off, ssz tile, ssz split, int stream, ld *acc,
                      u128 *ex, struct ck_marks *mk)
{
    if (!stream) mk = NULL; /* the marks follow the terms in order: stream mode only */
    int levels = ck_levels(n);
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
        Y = ck_big_alloc(sizeof(double) * (size_t)(Q * M));
        if (!Y) return -1;
        memset(Y + LY, 0, sizeof(double) * (size_t)(Q * M - LY));
    }
    b0 = malloc(sizeof(double) * (size_t)(T + M));
    b1 = malloc(sizeof(double) * (size_t)(T + M));
    if (!b0 || !b1) {
        free(Y);
        free(b0);
        free(b1);
        return -1;
    }
    for (ssz a = 0; a < LY; a += T) {
        ssz b = a + T + M - 1 < n ? a + T + M - 1 : n;
        ssz L = b - a;
        int last = a + T >= LY;
        double *buf = b0, *nxt = b1;
        ck_load(x, fmt, a, L, off, buf);
        for (int k = 0; k < K; k++) {
            ssz m = (ssz)1 << k;
            ssz c = n - 2 * m + 1 - a;
            if (!last && c > T) c = T;
            if (c <= 0) break;
            L -= m;
            /* the last level writes y_M straight into Y: its L values are the
             * tile's share, min(T, LY - a) */
            double *dst = Y && k == K - 1 ? Y + a : nxt;
            acc[k] = step_marked(buf, m, c, L, dst, ex ? ex + k : NULL, mk, k, a, acc[k]);
            nxt = buf;
            buf = dst;
        }
        if (Y && K == 0) memcpy(Y + a, buf, sizeof(double) * (size_t)(T < LY - a ? T : LY - a));
    }
    free(b0);
    free(b1);
    if (stream) {
        chains(x, fmt, n, K, levels, acc, ex, mk);
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
    if (!t0 || !t1) {
        free(Y);
        free(t0);
        free(t1);
        return -1;
    }
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
            acc[k] += ck_step(src, s, cnt, cnt, dst, ex ? ex + k : NULL);
            double *t = src;
            src = dst;
            dst = t;
        }
    }
    free(t0);
    free(t1);
    free(Y);
    return 0;
}

/* ---- non-overlapping octave sums -------------------------------------------- */

/* Cluster sums cascade S_2m[j] = S_m[2j] + S_m[2j+1] inside chunks; the pair
 * across a chunk boundary uses the previous chunk's last sum (slot 0). */

int ck_octave_nonoverlap(const void *x, int fmt, ssz n, double off, ssz chunk, ld *acc, u128 *ex)
{
    int levels = ck_levels(n);
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
        if (!bufs[k]) {
            for (int j = 0; j < k; j++) free(bufs[j]);
            free(top);
            return -1;
        }
    }
    ssz ntop = 0;
    for (ssz a = 0; a < n; a += chunk) {
        ssz L = a + chunk <= n ? chunk : n - a;
        ck_load(x, fmt, a, L, off, bufs[0] + 1);
        for (int k = 0; k < inner; k++) {
            double *buf = bufs[k];
            ssz lo = have[k] ? 0 : 1; /* slot 0: the previous chunk's last sum */
            if (L + 1 - lo >= 2) acc[k] += ck_step(buf + lo, 1, L - lo, 0, NULL, ex ? ex + k : NULL);
            if (L >= 1) {
                buf[0] = buf[L];
                have[k] = 1;
            }
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
            if (ex)
                ex[k] += sq((int64_t)d);
            else
                s += (ld)d * d;
        }
        acc[k] = s;
    }
    for (int k = 0; k < inner; k++) free(bufs[k]);
    free(top);
    return 0;
}
