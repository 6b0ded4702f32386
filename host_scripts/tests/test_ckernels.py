"""The compiled kernels (stats/_ckernels.c) against the numpy path and against
references computed independently from the definitions: long double phase
sums for float data, Python integers for integer codes (exact equality).
Every grid (octave, log, all), every input kind (random, walk, ramp,
constant, short), every input type the kernels read, the streamed (memmap)
path on a file, and tiny tiles so that every stage boundary is crossed."""

import numpy as np
import pytest

from imu_allan.stats import allan, kernels

pytestmark = pytest.mark.skipif(not kernels.COMPILED, reason="the compiled kernels are not built (make ext)")
needs_longdouble = pytest.mark.skipif(
    np.finfo(np.longdouble).nmant < 60, reason="long double is no wider than float64 here"
)


def inputs(n: int, seed: int = 3) -> dict:
    rng = np.random.default_rng(seed)
    return {
        "random": rng.standard_normal(n) * 3.0 + 100.0,
        "walk": np.cumsum(rng.standard_normal(n)),
        "walk+white": np.cumsum(rng.standard_normal(n) * 0.01) + rng.standard_normal(n),
        "ramp": np.linspace(-50.0, 700.0, n) + rng.standard_normal(n) * 0.1,
        "constant": np.full(n, 512.25),
    }


def ref_sums(x: np.ndarray, ms, overlapping: bool) -> np.ndarray:
    """Sum of squared second differences of the phase, long double, mean removed."""
    xl = np.asarray(x, dtype=np.longdouble)
    X = np.concatenate(([np.longdouble(0)], np.cumsum(xl - xl.mean())))
    out = []
    for m in ms:
        P = X if overlapping else X[::m]
        s = m if overlapping else 1
        d = P[2 * s :] - 2 * P[s:-s] + P[: -2 * s]
        out.append(float(np.sum(d * d)) if d.size else np.nan)
    return np.array(out)


def exact_sums(codes: np.ndarray, ms, overlapping: bool) -> list:
    """The same with Python integers: exact."""
    X = [0]
    for c in codes.tolist():
        X.append(X[-1] + int(c))
    out = []
    for m in ms:
        step = 1 if overlapping else m
        idx = range(0, len(X) - 2 * m, step)
        out.append(sum((X[i + 2 * m] - 2 * X[i + m] + X[i]) ** 2 for i in idx))
    return out


def close(a, b, rtol):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    ok = np.isfinite(b)
    assert np.array_equal(ok, np.isfinite(a))
    scale = np.maximum(np.abs(b[ok]), 1e-300)
    zero = b[ok] == 0  # a constant input: every difference is 0
    assert np.all(np.abs(a[ok][zero]) <= 1e-20)
    assert np.all(np.abs(a[ok][~zero] - b[ok][~zero]) <= rtol * scale[~zero]), (a, b)


@needs_longdouble
@pytest.mark.parametrize("n", [2, 3, 5, 64, 1001, 4097, 70_001])
@pytest.mark.parametrize("stream", [False, True])
def test_octave_compiled_numpy_and_reference_agree(n, stream):
    for x in inputs(n, seed=n).values():
        off = float(kernels.offset(x[: kernels.HEAD]))
        ms = allan.tau_grid("octave", n // 2)
        c, terms = kernels.octave_oavar_sums(x, off, stream=stream)
        p, terms_p = kernels.octave_oavar_sums_numpy(x, off)
        assert list(terms) == list(terms_p) == list(n - 2 * ms + 1)
        close(c, ref_sums(x, ms, True), 1e-13)
        close(c, p, 1e-13)
        c, pairs = kernels.octave_avar_sums(x, off)
        p, pairs_p = kernels.octave_avar_sums_numpy(x, off)
        assert list(pairs) == list(pairs_p) == list(n // ms - 1)
        close(c, ref_sums(x, ms, False), 1e-13)
        close(c, p, 1e-13)


@needs_longdouble
@pytest.mark.parametrize("n", [2, 3, 17, 1000, 20_011])
@pytest.mark.parametrize("tile,split,chunk", [(1 << 7, 1 << 4, 1 << 5), (1 << 8, 1 << 2, 1 << 3)])
def test_tiny_tiles_cross_every_stage_and_chain(n, tile, split, chunk, monkeypatch):
    monkeypatch.setattr(kernels, "OCTAVE_TILE", tile)
    monkeypatch.setattr(kernels, "OCTAVE_SPLIT", split)
    x = inputs(n, seed=n)["walk+white"]
    off = float(kernels.offset(x[: kernels.HEAD]))
    ms = allan.tau_grid("octave", n // 2)
    for stream in (False, True):
        close(kernels.octave_oavar_sums(x, off, stream=stream)[0], ref_sums(x, ms, True), 1e-13)
    close(kernels.octave_avar_sums(x, off, chunk)[0], ref_sums(x, ms, False), 1e-13)


@needs_longdouble
@pytest.mark.parametrize("kind,n", [("log", 50_000), ("all", 300), ("decade", 9999)])
@pytest.mark.parametrize("overlapping", [True, False])
def test_any_grid_compiled_matches_reference(kind, n, overlapping):
    """1e-13, but 3e-13 on the ramp (750 units over the record against noise of
    0.1: the phase's float64 offsets from each block's straight line round
    at ~1e-12 of a term; exact-rational check of the worst m: 1.8e-13)."""
    ms = allan.tau_grid(kind, n // 2)
    for name, x in inputs(n, seed=7).items():
        off = float(kernels.offset(x[: kernels.HEAD]))
        close(
            kernels.any_m_sums(x, off, ms, overlapping),
            ref_sums(x, ms, overlapping),
            3e-13 if name == "ramp" else 1e-13,
        )


def test_any_grid_through_the_api_matches_the_numpy_path(monkeypatch):
    x = inputs(30_000)["walk+white"]
    ms = allan.tau_grid("log", 15_000)
    for fn in (allan.oavar, allan.avar):
        v, cnt = fn(x, ms)
        monkeypatch.setattr(kernels, "_C", None)
        w, cnt_w = fn(x, ms)
        monkeypatch.undo()
        assert list(cnt) == list(cnt_w)
        # the numpy path rounds the plain float64 phase: ~1e-12 on a walk
        np.testing.assert_allclose(v, w, rtol=1e-10, atol=0)
    v, cnt = allan.oavar(x[:10], [0, 1, 4, 5, 6])
    assert list(cnt) == [0, 9, 3, 1, 0] and np.isnan(v[0]) and np.isnan(v[-1])


@pytest.mark.parametrize("n", [3, 999, 5000])
def test_integer_codes_exact_on_every_grid(n):
    """Codes small enough that every partial sum and square is an exact float64
    integer: the kernels' sums equal Python's integer sums exactly."""
    codes = np.random.default_rng(n).integers(-40, 40, n).astype(np.int16)
    off = 0.0 if kernels.offset(codes[: kernels.HEAD]) == 0 else float(kernels.offset(codes[: kernels.HEAD]))
    c = codes.astype(np.int64) - int(off)
    octave = allan.tau_grid("octave", n // 2)
    assert list(kernels.octave_oavar_sums(codes, off)[0]) == exact_sums(c, octave, True)
    assert list(kernels.octave_oavar_sums(codes, off, stream=True)[0]) == exact_sums(c, octave, True)
    assert list(kernels.octave_avar_sums(codes, off)[0]) == exact_sums(c, octave, False)
    log = allan.tau_grid("log", n // 2)
    assert list(kernels.any_m_sums(codes, off, log, True)) == exact_sums(c, log, True)
    assert list(kernels.any_m_sums(codes, off, log, False)) == exact_sums(c, log, False)


@pytest.mark.parametrize(
    "dtype", [np.int8, np.uint8, np.int16, np.uint16, np.int32, np.uint32, np.int64, np.uint64, np.float32]
)
def test_every_input_type_reads_as_float64(dtype):
    x = np.random.default_rng(1).integers(0, 100, 20_000).astype(dtype)
    wide = x.astype(np.float64)
    ms = allan.tau_grid("octave", x.size // 2)
    for fn in (allan.oavar, allan.avar):
        np.testing.assert_array_equal(fn(x, ms)[0], fn(wide, ms)[0])
    log = allan.tau_grid("log", x.size // 2)  # integer codes: integral block lines, exact sums
    np.testing.assert_allclose(allan.oavar(x, log)[0], allan.oavar(wide, log)[0], rtol=1e-14, atol=0)


def test_streamed_file_equals_in_memory(tmp_path, monkeypatch):
    """octave_mapped on an .npy file: integer codes exactly as in memory, and
    floats within 1e-13, at every octave, stride 1; small tiles so that most
    levels are running differences over the mapping."""
    monkeypatch.setattr(kernels, "OCTAVE_TILE", 1 << 10)
    monkeypatch.setattr(kernels, "OCTAVE_SPLIT", 1 << 6)
    n = 200_003
    codes = np.random.default_rng(4).integers(480, 540, n).astype(np.int16)
    path = tmp_path / "codes.npy"
    np.save(path, codes)
    r = allan.octave_mapped(np.load(path, mmap_mode="r"))
    ms = allan.tau_grid("octave", n // 2)
    assert list(r.ms) == list(ms) and np.all(r.stride == 1) and r.n == n
    assert list(r.terms) == list(n - 2 * ms + 1)
    np.testing.assert_array_equal(r.oavar[:, 0], allan.oavar(codes, ms)[0])
    np.testing.assert_array_equal(r.avar[:, 0], allan.avar(codes, ms)[0])
    x = inputs(n)["walk+white"]
    np.save(path, x)
    r = allan.octave_mapped(np.load(path, mmap_mode="r"))
    np.testing.assert_allclose(r.oavar[:, 0], allan.oavar(x, ms)[0], rtol=1e-13, atol=0)
    np.testing.assert_allclose(r.avar[:, 0], allan.avar(x, ms)[0], rtol=1e-13, atol=0)


def test_bad_buffers_are_refused():
    out = np.zeros(4)
    with pytest.raises(TypeError):
        kernels._C.octave_overlap(np.zeros((2, 8)), 0.0, out)
    with pytest.raises(ValueError):
        kernels._C.octave_overlap(np.zeros(64), 0.0, np.zeros(2))
    with pytest.raises(ValueError):
        kernels._C.octave_overlap(np.zeros(64), 0.0, np.zeros(8), 100)


@pytest.mark.parametrize("n", [1000, 70_001])
@pytest.mark.parametrize("stream", [False, True])
def test_large_integer_codes_exact_sums_rounded_once(n, stream, monkeypatch):
    """25-bit codes (a walk folded into range): squares and sums far above 2^53,
    where float64 squares and sums would round; the kernels' sums are the exact integer
    sums (Python ints) rounded once, on every grid."""
    monkeypatch.setattr(kernels, "OCTAVE_SPLIT", 1 << 6)
    monkeypatch.setattr(kernels, "OCTAVE_TILE", 1 << 10)
    rng = np.random.default_rng(n)
    codes = (np.cumsum(rng.integers(-(1 << 20), 1 << 20, n)) % (1 << 25)).astype(np.int32)
    off = float(kernels.offset(codes[: kernels.HEAD]))
    c = codes.astype(np.int64) - int(off)
    octave = allan.tau_grid("octave", n // 2)
    want = [float(v) for v in exact_sums(c, octave, True)]
    assert max(want) > 2.0**64
    assert list(kernels.octave_oavar_sums(codes, off, stream=stream)[0]) == want
    assert list(kernels.octave_avar_sums(codes, off, 1 << 5)[0]) == [float(v) for v in exact_sums(c, octave, False)]
    log = allan.tau_grid("log", n // 2)
    assert list(kernels.any_m_sums(codes, off, log, True)) == [float(v) for v in exact_sums(c, log, True)]
    assert list(kernels.any_m_sums(codes, off, log, False)) == [float(v) for v in exact_sums(c, log, False)]


def test_integers_too_large_for_exact_sums_take_the_float_path():
    """int64 codes of 2^45: partial sums beyond 2^52, so no exact mode; the
    float path still matches the long double reference."""
    x = np.random.default_rng(9).integers(-(1 << 45), 1 << 45, 1000)
    off = float(kernels.offset(x[: kernels.HEAD]))
    assert kernels._exact(x, off) == 0
    assert kernels._exact(x >> 30, 0.0) == 1  # 2^15: exact again
    ms = allan.tau_grid("octave", 500)
    close(kernels.octave_oavar_sums(x, off)[0], ref_sums(x, ms, True), 1e-13)
