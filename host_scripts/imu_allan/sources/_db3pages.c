/* The rows of a ROS 2 bag's messages table read from the leaf pages of its
 * table b-tree, as the SQLite file format documents them
 * (https://www.sqlite.org/fileformat2.html, sections 1.6 and 2.1): sqlite's
 * own per-row work (a virtual machine step, a record decoded into values)
 * was most of a bag's reading time.
 *
 * Only what rosbags' and rosbag2's writers make is read, and checked on
 * every cell: a leaf page of a table (type 13), cells whose rowids increase,
 * records of four columns (the rowid alias id stored as NULL, topic_id and
 * timestamp integers, data a blob). A row of a wanted topic whose payload
 * overflows its page, or anything else, stops the pass with a negative
 * status: the caller reads the rest through sqlite. Nothing outside the
 * buffer is read, whatever its bytes.  No Python objects but the arguments. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdint.h>
#include <string.h>

/* A varint at p (at most 9 bytes, none past end): its length, 0 when cut short. */
static int varint(const uint8_t *p, const uint8_t *end, uint64_t *v)
{
  uint64_t x = 0;
  for (int i = 0; i < 8; i++) {
    if (p + i >= end)
      return 0;
    x = (x << 7) | (p[i] & 0x7f);
    if (!(p[i] & 0x80)) {
      *v = x;
      return i + 1;
    }
  }
  if (p + 8 >= end)
    return 0;
  *v = (x << 8) | p[8];
  return 9;
}

/* An integer column of serial type t at p (big-endian two's complement); -1 when not an integer. */
static int integer(uint64_t t, const uint8_t *p, const uint8_t *end, int64_t *v)
{
  static const int size[] = {0, 1, 2, 3, 4, 6, 8};
  if (t == 8 || t == 9) {
    *v = (int64_t)t - 8;
    return 0;
  }
  if (t < 1 || t > 6 || p + size[t] > end)
    return -1;
  int64_t x = (int8_t)p[0]; /* the sign from the first byte */
  for (int i = 1; i < size[t]; i++)
    x = (int64_t)((uint64_t)x << 8 | p[i]);
  *v = x;
  return size[t];
}

enum { BAD_PAGE = -1, BAD_CELL = -2, OVERFLOW = -3, FULL = -4, ORDER = -5 };

typedef struct {
  const uint8_t *want; /* want[topic_id] for topic ids below nwant */
  int64_t nwant;
  uint8_t *raw;
  int64_t raw_cap, raw_len;
  int64_t *lens, *times, *ids;
  int64_t cap, k; /* rows of the wanted topics */
  int64_t rows;   /* every row */
  int64_t first;  /* the first rowid */
  int64_t last;   /* the last rowid */
  /* leaf_imu: each wanted row's sensor_msgs/Imu fields instead of its bytes */
  double *vals;           /* (6, vstride): ax ay az gx gy gz */
  int64_t vstride;        /* doubles from one channel's row to the next */
  int64_t *stamps, *keys; /* header stamp (ns); layout: 2 x length + 1 if big-endian */
  uint8_t *odd;           /* 1: not the standard CDR layout, its values meaningless */
} Out;

/* CDR's layout (imumsg.py): a 4-byte encapsulation header, stamp sec int32 and
 * nanosec uint32, frame_id (uint32 length counting its NUL, bytes), padding to
 * 8, then 37 float64: angular_velocity at the 13th, linear_acceleration at the 25th. */
enum { CDR_FIXED = 4 + 8 * 37, CDR_FLOOR = CDR_FIXED + 16, GYRO_AT = 13 * 8, ACC_AT = 25 * 8 };

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
#  define HOST_BIG 1
#else
#  define HOST_BIG 0
#endif

/* Unsigned 32 bits at p in the message's byte order (big: big-endian). */
static uint32_t u32(const uint8_t *p, int big)
{
  uint32_t x;
  memcpy(&x, p, sizeof x);
  return big == HOST_BIG ? x : __builtin_bswap32(x);
}

static double f64(const uint8_t *p, int big)
{
  uint64_t x;
  memcpy(&x, p, sizeof x);
  if (big != HOST_BIG)
    x = __builtin_bswap64(x);
  double d;
  memcpy(&d, &x, sizeof d);
  return d;
}

/* One message m of len bytes as imumsg.decode reads it: the six values and
 * the stamp of a message at least CDR_FLOOR long (zeros below), odd unless
 * its encapsulation is plain CDR in its byte order and its frame_id's length
 * gives its total length. */
static void imu_row(const uint8_t *m, int64_t len, Out *o)
{
  int64_t k = o->k, s = o->vstride;
  int big = len >= 4 && m[1] == 0, odd = 1;
  o->keys[k] = len * 2 + big;
  if (len < CDR_FLOOR) {
    o->stamps[k] = 0;
    for (int c = 0; c < 6; c++)
      o->vals[c * s + k] = 0.0;
  } else {
    int64_t flen = u32(m + 12, big), base = len - 8 * 37;
    odd = !((m[0] << 8 | m[1]) == (big ? 0 : 1) && flen >= 1 && (12 + flen + 7) / 8 * 8 == len - CDR_FIXED);
    o->stamps[k] = (int64_t)(int32_t)u32(m + 4, big) * 1000000000 + u32(m + 8, big);
    for (int c = 0; c < 3; c++) {
      o->vals[c * s + k] = f64(m + base + ACC_AT + 8 * c, big);
      o->vals[(c + 3) * s + k] = f64(m + base + GYRO_AT + 8 * c, big);
    }
  }
  o->odd[k] = (uint8_t)odd;
}

/* One cell at c of a leaf page ending at end; usable: the page's usable size. */
static int cell(const uint8_t *c, const uint8_t *end, int64_t usable, Out *o)
{
  uint64_t size, rowid, hsize, t[4];
  int n = varint(c, end, &size);
  if (!n)
    return BAD_CELL;
  c += n;
  if (!(n = varint(c, end, &rowid)))
    return BAD_CELL;
  c += n;
  if ((int64_t)rowid <= o->last)
    return ORDER;
  if (!o->rows)
    o->first = (int64_t)rowid;
  o->last = (int64_t)rowid;
  const uint8_t *rec = c;
  int64_t local = (int64_t)size, most = usable - 35;
  if (local > most) { /* spills to overflow pages: only its start is here */
    int64_t m = (usable - 12) * 32 / 255 - 23, k = m + ((int64_t)size - m) % (usable - 4);
    local = k <= most ? k : m;
  }
  const uint8_t *stop = rec + local;
  if (stop > end)
    return BAD_CELL;
  if (!(n = varint(rec, stop, &hsize)) || hsize > (uint64_t)local)
    return BAD_CELL;
  const uint8_t *h = rec + n, *body = rec + hsize;
  for (int i = 0; i < 4; i++) {
    if (h >= body || !(n = varint(h, body, &t[i])))
      return BAD_CELL;
    h += n;
  }
  if (h != body || t[0] != 0 || t[3] < 12 || t[3] % 2)
    return BAD_CELL;
  int64_t topic, stamp;
  const uint8_t *p = body;
  if ((n = integer(t[1], p, stop, &topic)) < 0)
    return BAD_CELL;
  p += n;
  if ((n = integer(t[2], p, stop, &stamp)) < 0)
    return BAD_CELL;
  p += n;
  int64_t len = (int64_t)(t[3] - 12) / 2;
  o->rows++;
  if (topic < 0 || topic >= o->nwant || !o->want[topic])
    return 0;
  if (local != (int64_t)size)
    return OVERFLOW;
  if (p + len != stop)
    return BAD_CELL;
  if (o->k == o->cap || (!o->vals && o->raw_len + len > o->raw_cap))
    return FULL;
  if (o->vals) {
    imu_row(p, len, o);
  } else {
    memcpy(o->raw + o->raw_len, p, (size_t)len);
    o->raw_len += len;
  }
  o->lens[o->k] = len;
  o->times[o->k] = stamp;
  o->ids[o->k] = (int64_t)rowid;
  o->k++;
  return 0;
}

static int leaf(const uint8_t *pg, int64_t page_size, int64_t usable, Out *o)
{
  const uint8_t *end = pg + usable;
  if (pg[0] != 13)
    return BAD_PAGE;
  int64_t ncell = pg[3] << 8 | pg[4];
  if (8 + 2 * ncell > usable)
    return BAD_PAGE;
  for (int64_t i = 0; i < ncell; i++) {
    int64_t at = pg[8 + 2 * i] << 8 | pg[9 + 2 * i];
    if (at < 8 + 2 * ncell || at >= usable)
      return BAD_CELL;
    int r = cell(pg + at, end, usable, o);
    if (r < 0)
      return r;
  }
  (void)page_size;
  return 0;
}

#define ARR(b, T) ((T *)(b).buf)

/* The leaf pages at offsets at (int64) in buf into o; the GIL let go meanwhile. */
static int pages(Py_buffer *buf, Py_buffer *at, Py_ssize_t page_size, Py_ssize_t usable, Out *o)
{
  int status = 0;
  Py_ssize_t npage = at->len / 8;
  Py_BEGIN_ALLOW_THREADS;
  for (Py_ssize_t done = 0; done < npage && status == 0; done++) {
    int64_t off = ARR(*at, int64_t)[done];
    if (off < 0 || off + page_size > buf->len || usable > page_size || usable < 480)
      status = BAD_PAGE;
    else
      status = leaf((const uint8_t *)buf->buf + off, page_size, usable, o);
  }
  Py_END_ALLOW_THREADS;
  return status;
}

static Py_ssize_t least(Py_ssize_t a, Py_ssize_t b)
{
  return a < b ? a : b;
}

static PyObject *leaf_rows(PyObject *self, PyObject *args)
{
  Py_buffer buf, at, want, raw, lens, times, ids;
  Py_ssize_t page_size, usable;
  long long last;
  (void)self;
  if (!PyArg_ParseTuple(args, "y*y*nny*Lw*w*w*w*", &buf, &at, &page_size, &usable, &want, &last, &raw, &lens,
                        &times, &ids))
    return NULL;
  Out o = {0};
  o.want = want.buf, o.nwant = want.len, o.raw = raw.buf, o.raw_cap = raw.len, o.last = last;
  o.lens = ARR(lens, int64_t), o.times = ARR(times, int64_t), o.ids = ARR(ids, int64_t);
  o.cap = least(least(lens.len, times.len), ids.len) / 8;
  int status = pages(&buf, &at, page_size, usable, &o);
  PyBuffer_Release(&buf), PyBuffer_Release(&at), PyBuffer_Release(&want), PyBuffer_Release(&raw);
  PyBuffer_Release(&lens), PyBuffer_Release(&times), PyBuffer_Release(&ids);
  return Py_BuildValue("iLLLL", status, (long long)o.k, (long long)o.raw_len, (long long)o.first,
                       (long long)o.last);
}

static PyObject *leaf_imu(PyObject *self, PyObject *args)
{
  Py_buffer buf, at, want, lens, times, ids, vals, stamps, keys, odd;
  Py_ssize_t page_size, usable;
  long long last;
  (void)self;
  if (!PyArg_ParseTuple(args, "y*y*nny*Lw*w*w*w*w*w*w*", &buf, &at, &page_size, &usable, &want, &last, &lens,
                        &times, &ids, &vals, &stamps, &keys, &odd))
    return NULL;
  Out o = {0};
  o.want = want.buf, o.nwant = want.len, o.last = last;
  o.lens = ARR(lens, int64_t), o.times = ARR(times, int64_t), o.ids = ARR(ids, int64_t);
  o.stamps = ARR(stamps, int64_t), o.keys = ARR(keys, int64_t), o.odd = odd.buf, o.vals = ARR(vals, double);
  o.cap =
      least(least(least(lens.len, times.len), least(ids.len, stamps.len)), least(keys.len, 8 * odd.len)) / 8;
  o.vstride = o.cap = least(o.cap, vals.len / 48);
  int status = pages(&buf, &at, page_size, usable, &o);
  PyBuffer_Release(&buf), PyBuffer_Release(&at), PyBuffer_Release(&want), PyBuffer_Release(&lens);
  PyBuffer_Release(&times), PyBuffer_Release(&ids), PyBuffer_Release(&vals), PyBuffer_Release(&stamps);
  PyBuffer_Release(&keys), PyBuffer_Release(&odd);
  return Py_BuildValue("iLLL", status, (long long)o.k, (long long)o.first, (long long)o.last);
}

static PyMethodDef methods[] = {
    {"leaf_rows", leaf_rows, METH_VARARGS,
     "leaf_rows(buf, at, page_size, usable, want, last, raw, lens, times, ids)\n"
     "-> (status, k, raw_len, first, last): the rows of the table leaf pages at offsets at (int64) in buf\n"
     "whose topic_id t has want[t] (uint8): data into raw, lengths, timestamps and rowids into the\n"
     "int64 arrays; rowids above last. status < 0: stopped (-1 page, -2 cell, -3 overflow, -4 full, -5 order)."},
    {"leaf_imu", leaf_imu, METH_VARARGS,
     "leaf_imu(buf, at, page_size, usable, want, last, lens, times, ids, vals, stamps, keys, odd)\n"
     "-> (status, k, first, last): leaf_rows' rows decoded as sensor_msgs/Imu in CDR, as imumsg.decode\n"
     "does, instead of copied: vals (6, cap) float64 C-contiguous (cap: the rows the arrays hold),\n"
     "stamps and keys int64, odd uint8 (1: not the standard layout)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT,
                                    "_db3pages",
                                    "Rows of a ROS 2 bag's messages table from its leaf pages.",
                                    -1,
                                    methods,
                                    NULL,
                                    NULL,
                                    NULL,
                                    NULL};

PyMODINIT_FUNC PyInit__db3pages(void)
{
  return PyModule_Create(&module);
}
