/* Allan sums at any cluster sizes (log, decade, all grids) from the phase. */
#include <stdlib.h>

#include "ckernels.h"

/* ---- any cluster sizes, from the phase --------------------------------------- */

/* The phase X(i) = sum_{j<i} (x_j - off), i = 0 .. n, stored as
 *   X(i) = base[b] + mu[b] * (i - b PBLOCK) + rel[i],   b = i / PBLOCK,
 * base in long double, mu the block's mean rate, rel in float64: rel stays
 * small (a block's deviation from its own straight line) even for a walk or a
 * ramp far from the offset, so second differences lose no digits to it. */
struct phase {
    double *rel, *mu;
    ld *base;
};

static int phase(const void *x, int fmt, ssz n, double off, int exact, struct phase *ph)
{
    ssz nb = n / PBLOCK + 1;
    ph->rel = malloc(sizeof(double) * (size_t)(n + 1));
    ph->mu = malloc(sizeof(double) * (size_t)nb);
    ph->base = malloc(sizeof(ld) * (size_t)nb);
    double tmp[PBLOCK];
    if (!ph->rel || !ph->mu || !ph->base) {
        free(ph->rel);
        free(ph->mu);
        free(ph->base);
        return -1;
    }
    ld X = 0;
    for (ssz b = 0; b < nb; b++) {
        ssz a = b * PBLOCK;
        ssz cnt = PBLOCK < n - a ? PBLOCK : n - a; /* samples a .. a+cnt-1: points a+1 .. a+cnt */
        ck_load(x, fmt, a, cnt, off, tmp);
        ld r = 0;
        for (ssz i = 0; i < cnt; i++) r += tmp[i];
        double mu = cnt > 0 ? (double)(r / cnt) : 0.0;
        if (exact) mu = rint(mu); /* integer codes: an integral line keeps rel integral */
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
        a0 += d0 * d0;
        a1 += d1 * d1;
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
    ssz c = n - 2 * m + 1; /* terms i = 0 .. c-1 */
    ld total = 0;
    for (ssz i = 0; i < c;) {
        ssz p0 = i, p1 = i + m, p2 = i + 2 * m;
        ssz b0 = p0 / PBLOCK, b1 = p1 / PBLOCK, b2 = p2 / PBLOCK;
        ssz e = c - i, r;
        if ((r = (b0 + 1) * PBLOCK - p0) < e) e = r;
        if ((r = (b1 + 1) * PBLOCK - p1) < e) e = r;
        if ((r = (b2 + 1) * PBLOCK - p2) < e) e = r;
        /* the blocks' straight lines: c0 + j c1 over the segment */
        ld c0 = ph->base[b2] + (ld)ph->mu[b2] * (ld)(p2 - b2 * PBLOCK) -
                2 * (ph->base[b1] + (ld)ph->mu[b1] * (ld)(p1 - b1 * PBLOCK)) + ph->base[b0] +
                (ld)ph->mu[b0] * (ld)(p0 - b0 * PBLOCK);
        ld c1 = (ld)ph->mu[b2] - 2 * (ld)ph->mu[b1] + (ld)ph->mu[b0];
        double bs = seg2(ph->rel + p0, ph->rel + p1, ph->rel + p2, e, (double)c0, (double)c1);
        if (!ex)
            total += bs;
        else if (bs < EXACT_BLOCK)
            *ex += (u128)(uint64_t)bs;
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
        if (ex)
            *ex += sq((int64_t)d);
        else
            total += d * d;
    }
    return total;
}

int ck_any_m(const void *x, int fmt, ssz n, double off, const int64_t *ms, ssz nm, int overlapping, int exact,
             double *out)
{
    struct phase ph;
    if (phase(x, fmt, n, off, exact, &ph)) return -1;
    for (ssz j = 0; j < nm; j++) {
        ssz m = ms[j];
        ssz terms = overlapping ? n - 2 * m + 1 : (m > 0 ? n / m - 1 : 0);
        if (m < 1 || terms < 1) {
            out[j] = NAN;
            continue;
        }
        u128 e = 0;
        ld f = overlapping ? overlap_m(&ph, n, m, exact ? &e : NULL) :
                             nonoverlap_m(&ph, n, m, exact ? &e : NULL);
        out[j] = exact ? (double)e : (double)f;
    }
    free(ph.rel);
    free(ph.mu);
    free(ph.base);
    return 0;
}
