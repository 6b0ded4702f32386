/* Compiled Allan kernels of imu_allan.stats (kernels.py keeps the numpy path
 * as the fallback when this extension is not built).
 *
 * Plain C with the buffer protocol: no numpy headers.  This file is the
 * Python glue; the kernels are in ck_core.c, ck_octave.c and ck_phase.c, the
 * numeric text readers (rows and delimited tables) in ck_text.c.  Every function takes a
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

#include "ckernels.h"

/* ---- input formats (the buffer protocol's struct codes) -------------------- */

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
    case 'i':
    case 'l':
    case 'q': return v->itemsize == 8 ? I64 : v->itemsize == 4 ? I32 : -1;
    case 'I':
    case 'L':
    case 'Q': return v->itemsize == 8 ? U64 : v->itemsize == 4 ? U32 : -1;
    }
    return -1;
}

/* ---- Python glue -------------------------------------------------------------- */

static int get_in(PyObject *obj, Py_buffer *v, int *fmt)
{
    if (PyObject_GetBuffer(obj, v, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) return -1;
    if (v->ndim != 1 || (*fmt = parse_fmt(v)) < 0) {
        PyBuffer_Release(v);
        PyErr_SetString(PyExc_TypeError,
                        "x: a contiguous 1-D buffer of int8..64, uint8..64, float32 or float64");
        return -1;
    }
    return 0;
}

static int get_out(PyObject *obj, Py_buffer *v, ssz need)
{
    if (PyObject_GetBuffer(obj, v, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE) < 0) return -1;
    if (v->ndim != 1 || v->itemsize != 8 || !v->format || strchr(v->format, 'd') == NULL ||
        v->shape[0] < need) {
        PyBuffer_Release(v);
        PyErr_SetString(PyExc_ValueError, "out: a writable float64 buffer, one slot per level");
        return -1;
    }
    return 0;
}

/* The optional windows of the overlapping sums (struct ck_marks): starts (int64,
 * W), size and out (float64, levels x W); none when starts is None. */
static int get_marks(PyObject *so, Py_ssize_t size, PyObject *wo, int levels, Py_buffer *sv, Py_buffer *wv,
                     struct ck_marks *mk, struct ck_marks **use)
{
    *use = NULL;
    if (so == NULL || so == Py_None) return 0;
    if (PyObject_GetBuffer(so, sv, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) return -1;
    if (sv->ndim != 1 || sv->itemsize != 8 || !sv->format || !strpbrk(sv->format, "qlL") || size < 1) {
        PyBuffer_Release(sv);
        PyErr_SetString(PyExc_ValueError, "starts: int64 window starts; size >= 1");
        return -1;
    }
    ssz W = sv->shape[0];
    if (get_out(wo, wv, (ssz)levels * W) < 0) {
        PyBuffer_Release(sv);
        return -1;
    }
    const int64_t *st = sv->buf;
    for (ssz w = 0; w < W; w++)
        if (st[w] < 0 || (w && st[w] < st[w - 1])) {
            PyBuffer_Release(sv);
            PyBuffer_Release(wv);
            PyErr_SetString(PyExc_ValueError, "starts: non-negative and in order");
            return -1;
        }
    if (ck_marks_init(mk, levels, st, W, size, wv->buf) < 0) {
        PyBuffer_Release(sv);
        PyBuffer_Release(wv);
        PyErr_NoMemory();
        return -1;
    }
    *use = mk;
    return 0;
}

static void free_marks(struct ck_marks *use, Py_buffer *sv, Py_buffer *wv)
{
    if (!use) return;
    free(use->mem);
    PyBuffer_Release(sv);
    PyBuffer_Release(wv);
}

static PyObject *py_octave(PyObject *args, int kind)
{
    PyObject *xo, *oo, *so = NULL, *wo = NULL;
    double off;
    Py_ssize_t p1 = 1 << 17, p2 = 1 << 14, size = 0;
    int stream = 0, exact = 0;
    if (kind == 0) {
        if (!PyArg_ParseTuple(args, "OdO|nniiOnO", &xo, &off, &oo, &p1, &p2, &stream, &exact, &so, &size,
                              &wo))
            return NULL;
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
    int levels = ck_levels(n);
    if (get_out(oo, &ov, levels) < 0) {
        PyBuffer_Release(&xv);
        return NULL;
    }
    ld acc[MAXLEV];
    u128 ex[MAXLEV];
    int rc;
    memset(ex, 0, sizeof ex);
    struct ck_marks mk, *use = NULL;
    Py_buffer sv, wv;
    if (kind == 0 && stream && get_marks(so, size, wo, levels, &sv, &wv, &mk, &use) < 0) {
        PyBuffer_Release(&xv);
        PyBuffer_Release(&ov);
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS rc =
        kind == 0 ? ck_octave_overlap(xv.buf, fmt, n, off, p1, p2, stream, acc, exact ? ex : NULL, use) :
                    ck_octave_nonoverlap(xv.buf, fmt, n, off, p1, acc, exact ? ex : NULL);
    if (use && !rc) ck_marks_done(use, levels, acc, exact ? ex : NULL);
    Py_END_ALLOW_THREADS for (int k = 0; k < levels; k++) /* exact: the integer sum, rounded once */
        ((double *)ov.buf)[k] = exact ? (double)ex[k] : (double)acc[k];
    free_marks(use, &sv, &wv);
    PyBuffer_Release(&xv);
    PyBuffer_Release(&ov);
    if (rc) return PyErr_NoMemory();
    return PyLong_FromLong(levels);
}

static PyObject *octave_overlap(PyObject *self, PyObject *args)
{
    (void)self;
    return py_octave(args, 0);
}
static PyObject *octave_nonoverlap(PyObject *self, PyObject *args)
{
    (void)self;
    return py_octave(args, 1);
}

/* octave_file(fd, code, n, off, over, non, exact=0): the overlapping (stream
 * mode: O(1) memory) and non-overlapping octave sums of n samples of struct
 * code ``code`` ('d', 'H' ...) stored from byte 0 of the open file fd, read
 * with pread: the same numbers as octave_overlap(stream=1) and
 * octave_nonoverlap on the same samples in memory. */
static PyObject *octave_file(PyObject *self, PyObject *args)
{
    (void)self;
    int fd, exact = 0;
    const char *code;
    Py_ssize_t n, size = 0;
    double off;
    PyObject *oo, *no, *so = NULL, *wo = NULL;
    if (!PyArg_ParseTuple(args, "isndOO|iOnO", &fd, &code, &n, &off, &oo, &no, &exact, &so, &size, &wo))
        return NULL;
    if (exact && !EXACT_OK) {
        PyErr_SetString(PyExc_ValueError, "exact: no 128-bit integers in this build");
        return NULL;
    }
    Py_buffer probe = {0};
    probe.format = (char *)code;
    probe.itemsize = code[0] == 'd' || code[0] == 'q' || code[0] == 'Q' ? 8 :
                     code[0] == 'f' || code[0] == 'i' || code[0] == 'I' ? 4 :
                                                                          0;
    int fmt = parse_fmt(&probe);
    if (fmt < 0 || n < 0) {
        PyErr_SetString(PyExc_TypeError, "code: a struct code of a number (d f q i h b Q I H B)");
        return NULL;
    }
    int levels = ck_levels(n);
    Py_buffer ov, nv;
    if (get_out(oo, &ov, levels) < 0) return NULL;
    if (get_out(no, &nv, levels) < 0) {
        PyBuffer_Release(&ov);
        return NULL;
    }
    struct ck_file f = {fd, fmt, 0, 0};
    ld acc[MAXLEV], nacc[MAXLEV];
    u128 ex[MAXLEV], nex[MAXLEV];
    int rc;
    memset(ex, 0, sizeof ex);
    memset(nex, 0, sizeof nex);
    struct ck_marks mk, *use = NULL;
    Py_buffer sv, wv;
    if (get_marks(so, size, wo, levels, &sv, &wv, &mk, &use) < 0) {
        PyBuffer_Release(&ov);
        PyBuffer_Release(&nv);
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS rc =
        ck_octave_overlap(&f, CK_FILE, n, off, 1 << 17, 1 << 14, 1, acc, exact ? ex : NULL, use);
    if (use && !rc) ck_marks_done(use, levels, acc, exact ? ex : NULL);
    if (!rc) rc = ck_octave_nonoverlap(&f, CK_FILE, n, off, 1 << 16, nacc, exact ? nex : NULL);
    Py_END_ALLOW_THREADS for (int k = 0; k < levels; k++)
    {
        ((double *)ov.buf)[k] = exact ? (double)ex[k] : (double)acc[k];
        ((double *)nv.buf)[k] = exact ? (double)nex[k] : (double)nacc[k];
    }
    PyBuffer_Release(&ov);
    PyBuffer_Release(&nv);
    free_marks(use, &sv, &wv);
    if (rc) return PyErr_NoMemory();
    if (f.err) {
        PyErr_SetString(PyExc_OSError,
                        f.err == 1 ? "reading the samples' file failed" : "the samples' file is short");
        return NULL;
    }
    return PyLong_FromLong(levels);
}

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
    if (PyObject_GetBuffer(mo, &mv, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) {
        PyBuffer_Release(&xv);
        return NULL;
    }
    if (mv.ndim != 1 || mv.itemsize != 8 || parse_fmt(&mv) != I64) {
        PyBuffer_Release(&xv);
        PyBuffer_Release(&mv);
        PyErr_SetString(PyExc_TypeError, "ms: contiguous int64");
        return NULL;
    }
    if (get_out(oo, &ov, mv.shape[0]) < 0) {
        PyBuffer_Release(&xv);
        PyBuffer_Release(&mv);
        return NULL;
    }
    int rc;
    Py_BEGIN_ALLOW_THREADS rc =
        ck_any_m(xv.buf, fmt, xv.shape[0], off, mv.buf, mv.shape[0], overlapping, exact, ov.buf);
    Py_END_ALLOW_THREADS PyBuffer_Release(&xv);
    PyBuffer_Release(&mv);
    PyBuffer_Release(&ov);
    if (rc) return PyErr_NoMemory();
    Py_RETURN_NONE;
}

/* parse_rows(data, ncol, maxval, out, cap) -> rows, or -1 (a fault: the exact
 * reader names it).  out: writable uint16, (ncol, cap) channel-major. */
static PyObject *parse_rows(PyObject *self, PyObject *args)
{
    (void)self;
    Py_buffer d, o, l = {0};
    int ncol, maxval;
    Py_ssize_t cap, rows, lines = 0;
    if (!PyArg_ParseTuple(args, "y*iiw*n|w*", &d, &ncol, &maxval, &o, &cap, &l)) return NULL;
    if (ncol < 1 || cap < 0 || o.len < (Py_ssize_t)(ncol * cap * 2) || (l.buf && l.len < 8)) {
        PyBuffer_Release(&d);
        PyBuffer_Release(&o);
        if (l.buf) PyBuffer_Release(&l);
        PyErr_SetString(PyExc_ValueError, "out: at least ncol * cap uint16; lines: an int64");
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS rows = ck_parse_rows(d.buf, d.len, ncol, maxval, o.buf, cap, &lines);
    Py_END_ALLOW_THREADS PyBuffer_Release(&d);
    PyBuffer_Release(&o);
    if (l.buf) {
        *(int64_t *)l.buf = lines;
        PyBuffer_Release(&l);
    }
    return PyLong_FromSsize_t(rows);
}

/* parse_table(data, delim, which, tcol, out, tint, tflt, cap) -> (rows, time_is_float);
 * rows < 0: -(1 + the first line not plainly a row).  which: int32 per column. */
static PyObject *parse_table(PyObject *self, PyObject *args)
{
    (void)self;
    Py_buffer d, w, o, ti, tf;
    int delim, tcol, tfloat = 0;
    Py_ssize_t cap, rows;
    if (!PyArg_ParseTuple(args, "y*iy*iw*w*w*n", &d, &delim, &w, &tcol, &o, &ti, &tf, &cap)) return NULL;
    int ncols = (int)(w.len / (Py_ssize_t)sizeof(int)), nout = 0;
    for (int k = 0; k < ncols; k++)
        if (((const int *)w.buf)[k] >= nout) nout = ((const int *)w.buf)[k] + 1;
    int bad = cap < 0 || tcol >= ncols || o.len < (Py_ssize_t)(nout * cap * 8) ||
              (tcol >= 0 && (ti.len < cap * 8 || tf.len < cap * 8));
    struct ck_table t = {delim, w.buf, ncols, tcol, o.buf, cap, ti.buf, tf.buf, &tfloat};
    if (!bad) {
        Py_BEGIN_ALLOW_THREADS rows = ck_parse_table(d.buf, d.len, &t);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&d);
    PyBuffer_Release(&w);
    PyBuffer_Release(&o);
    PyBuffer_Release(&ti);
    PyBuffer_Release(&tf);
    if (bad) {
        PyErr_SetString(PyExc_ValueError, "parse_table: buffers too small for cap");
        return NULL;
    }
    return Py_BuildValue("ni", rows, tfloat);
}

/* diff_look(x, prev, has_prev, pos, step, sub, st) -> values put in sub;
 * diff_grid(x, prev, has_prev, q, gmax, cnt) -> not numbers: the outlier scan's two passes
 * over one piece (x: contiguous float64) of a channel's first differences. */
static PyObject *diff_look(PyObject *self, PyObject *args)
{
    (void)self;
    Py_buffer x, sub, st;
    double prev;
    int has_prev;
    Py_ssize_t pos, step, k = -1;
    if (!PyArg_ParseTuple(args, "y*dinnw*w*", &x, &prev, &has_prev, &pos, &step, &sub, &st)) return NULL;
    ssz n = x.len / 8;
    if (step >= 1 && st.len >= 32 && sub.len >= 8 * (n / step + 1)) {
        Py_BEGIN_ALLOW_THREADS k = ck_diff_look(x.buf, n, prev, has_prev, pos, step, sub.buf, st.buf);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&x);
    PyBuffer_Release(&sub);
    PyBuffer_Release(&st);
    if (k < 0) {
        PyErr_SetString(PyExc_ValueError, "diff_look: step >= 1, st of 4, sub of n / step + 1");
        return NULL;
    }
    return PyLong_FromSsize_t(k);
}

static PyObject *diff_grid(PyObject *self, PyObject *args)
{
    (void)self;
    Py_buffer x, cnt;
    double prev, q;
    int has_prev, gmax;
    if (!PyArg_ParseTuple(args, "y*didiw*", &x, &prev, &has_prev, &q, &gmax, &cnt)) return NULL;
    int ok = gmax >= 0 && q > 0 && cnt.len >= 8 * (2 * (Py_ssize_t)gmax + 1);
    Py_ssize_t bad = 0;
    if (ok) {
        Py_BEGIN_ALLOW_THREADS bad = ck_diff_grid(x.buf, x.len / 8, prev, has_prev, q, gmax, cnt.buf);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&x);
    PyBuffer_Release(&cnt);
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, "diff_grid: q > 0, cnt of 2 gmax + 1 int64");
        return NULL;
    }
    return PyLong_FromSsize_t(bad);
}

/* welch_prep(x, nseg, step, k, mean, window, out) and welch_acc(spec, k, nf, acc):
 * psd.Welch's segments, demeaned and windowed, and its periodograms summed. */
static PyObject *welch_prep(PyObject *self, PyObject *args)
{
    (void)self;
    Py_buffer x, m, w, o;
    Py_ssize_t nseg, step, k;
    int single = 0;
    if (!PyArg_ParseTuple(args, "y*nnny*y*w*|p", &x, &nseg, &step, &k, &m, &w, &o, &single)) return NULL;
    int ok = nseg >= 1 && step >= 1 && k >= 0 && x.len >= 8 * ((k ? (k - 1) * step : 0) + nseg) &&
             m.len >= 8 * k && w.len >= 8 * nseg && o.len >= (single ? 4 : 8) * k * nseg;
    if (ok) {
        Py_BEGIN_ALLOW_THREADS if (single) ck_welch_prep32(x.buf, nseg, step, k, m.buf, w.buf, o.buf);
        else ck_welch_prep(x.buf, nseg, step, k, m.buf, w.buf, o.buf);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&x);
    PyBuffer_Release(&m);
    PyBuffer_Release(&w);
    PyBuffer_Release(&o);
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, "welch_prep: buffers too small");
        return NULL;
    }
    Py_RETURN_NONE;
}

static PyObject *welch_acc(PyObject *self, PyObject *args)
{
    (void)self;
    Py_buffer z, a;
    Py_ssize_t k, nf;
    int single = 0;
    if (!PyArg_ParseTuple(args, "y*nnw*|p", &z, &k, &nf, &a, &single)) return NULL;
    int ok = k >= 0 && nf >= 0 && z.len >= (single ? 8 : 16) * k * nf && a.len >= 8 * nf;
    if (ok) {
        Py_BEGIN_ALLOW_THREADS if (single) ck_welch_acc32(z.buf, k, nf, a.buf);
        else ck_welch_acc(z.buf, k, nf, a.buf);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&z);
    PyBuffer_Release(&a);
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, "welch_acc: buffers too small");
        return NULL;
    }
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"welch_prep", welch_prep, METH_VARARGS,
     "welch_prep(x, nseg, step, k, mean, window, out, single=False)\n"
     "k segments of x, step apart: (x - mean[s]) * window into out (k, nseg; float32 if single)."},
    {"welch_acc", welch_acc, METH_VARARGS,
     "welch_acc(spec, k, nf, acc, single=False)\n"
     "acc += |spec[s]|^2 for each of k spectra (complex64 if single), in order."},
    {"diff_look", diff_look, METH_VARARGS,
     "diff_look(x, prev, has_prev, pos, step, sub, st) -> k\n"
     "First differences of a piece: every step-th into sub, min nonzero |d|, max, min into st."},
    {"diff_grid", diff_grid, METH_VARARGS,
     "diff_grid(x, prev, has_prev, q, gmax, cnt) -> differences not numbers\n"
     "Counts of rint(d / q) clipped to +-gmax of a piece's first differences."},
    {"parse_rows", parse_rows, METH_VARARGS,
     "parse_rows(data, ncol, maxval, out, cap, lines=None) -> rows (-1: a fault)\n"
     "Rows of ncol integer codes into out (uint16, (ncol, cap)); the line ends read into lines[0] (int64)."},
    {"parse_table", parse_table, METH_VARARGS,
     "parse_table(data, delim, which, tcol, out, tint, tflt, cap) -> (rows, time_is_float)\n"
     "Delimited numbers: wanted columns into out (float64, (k, cap)), the time column into tint/tflt."},
    {"octave_overlap", octave_overlap, METH_VARARGS,
     "octave_overlap(x, off, out, tile=2**17, split=2**14, stream=0, exact=0, starts=None, size=0, wout=None)\n"
     "-> levels. Overlapping octave sums of squares into out[k] (m = 2^k); stream=1 and starts:\n"
     "also each window's (starts[w], size samples) into wout[k * W + w]."},
    {"octave_nonoverlap", octave_nonoverlap, METH_VARARGS,
     "octave_nonoverlap(x, off, out, chunk=2**16, exact=0) -> levels\n"
     "Non-overlapping octave sums of squares into out[k]."},
    {"octave_file", octave_file, METH_VARARGS,
     "octave_file(fd, code, n, off, over, non, exact=0, starts=None, size=0, wout=None) -> levels\n"
     "Overlapping and non-overlapping octave sums of a file's n samples (pread); windows as octave_overlap."},
    {"any_m", any_m, METH_VARARGS,
     "any_m(x, off, ms, out, overlapping, exact=0)\n"
     "Sums of squared second differences of the phase at each m (nan where no term)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT,
                                    "_ckernels",
                                    "Compiled Allan kernels (see kernels.py).",
                                    -1,
                                    methods,
                                    NULL,
                                    NULL,
                                    NULL,
                                    NULL};

PyMODINIT_FUNC PyInit__ckernels(void)
{
    PyObject *m = PyModule_Create(&module);
    if (m && PyModule_AddIntConstant(m, "EXACT", EXACT_OK) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
