/* The compiled kernels' building blocks: scratch memory, reading any input
 * type, and the fused difference / square / moving-sum loop. */
#include <stdlib.h>
#include <unistd.h>
#if defined(__linux__)
#    include <sys/mman.h>
#endif

#include "ckernels.h"

/* A large scratch buffer: 2 MB aligned and, on Linux, backed by huge pages
 * where the kernel allows it (a fresh 80 MB buffer otherwise costs 20,000
 * page faults, as much time as the arithmetic). */
void *ck_big_alloc(size_t bytes)
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

static const int item_size[] = {8, 4, 8, 4, 2, 1, 8, 4, 2, 1}; /* by enum fmt */

/* A file's samples: read with pread in pieces of FILE_PIECE bytes, each
 * converted as an in-memory buffer would be (the same numbers). */
#define FILE_PIECE 65536
static void load_file(struct ck_file *f, ssz start, ssz count, double off, double *dst)
{
    unsigned char raw[FILE_PIECE];
    ssz size = item_size[f->fmt], per = FILE_PIECE / size;
    while (count > 0) {
        ssz k = count < per ? count : per;
        size_t want = (size_t)(k * size), got = 0;
        off_t at = (off_t)f->base + (off_t)start * size;
        while (got < want) {
            ssize_t r = pread(f->fd, raw + got, want - got, at + (off_t)got);
            if (r <= 0) { /* an error or a short file: NaN, and the caller is told */
                f->err = r < 0 ? 1 : 2;
                for (ssz i = 0; i < count; i++) dst[i] = NAN;
                return;
            }
            got += (size_t)r;
        }
        ck_load(raw, f->fmt, 0, k, off, dst);
        start += k;
        count -= k;
        dst += k;
    }
}

/* dst[i] = x[start + i] - off as double, i < count */
void ck_load(const void *x, int fmt, ssz start, ssz count, double off, double *dst)
{
#define LOAD(T)                                                                                              \
    do {                                                                                                     \
        const T *s = (const T *)x + start;                                                                   \
        for (ssz i = 0; i < count; i++) dst[i] = (double)s[i] - off;                                         \
    } while (0)
    if (fmt == CK_FILE) {
        load_file((struct ck_file *)x, start, count, off, dst);
        return;
    }
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

ld ck_value(const void *x, int fmt, ssz i)
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
HOT ld ck_step(const double *buf, ssz m, ssz c, ssz L, double *nxt, u128 *ex)
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
                st4(nxt + i, x0 + y0);
                st4(nxt + i + 4, x1 + y1);
                st4(nxt + i + 8, x2 + y2);
                st4(nxt + i + 12, x3 + y3);
                v4 d0 = y0 - x0, d1 = y1 - x1, d2 = y2 - x2, d3 = y3 - x3;
                a0 += d0 * d0;
                a1 += d1 * d1;
                a2 += d2 * d2;
                a3 += d3 * d3;
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
                a0 += d0 * d0;
                a1 += d1 * d1;
                a2 += d2 * d2;
                a3 += d3 * d3;
            }
            for (; i < e; i++) {
                double d = hi[i] - buf[i];
                t += d * d;
            }
        }
        double bs = hsum(a0, a1, a2, a3) + t;
        if (!ex) {
            total += bs;
        } else if (bs < EXACT_BLOCK) { /* every square and partial sum was an exact integer */
            *ex += (u128)(uint64_t)bs;
        } else { /* recount the block in integers */
            for (ssz k = s; k < e; k++) *ex += sq((int64_t)hi[k] - (int64_t)buf[k]);
        }
    }
    if (nxt)
        for (ssz i = c; i < L; i++) nxt[i] = buf[i] + hi[i];
    return total;
}
