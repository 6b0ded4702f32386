"""The streamed analysis (samples in per-channel files past --memory) reports
the numbers the in-memory one does, on generated and on real recordings; its
pieces (the file kernels, the outlier scan's passes) agree with independent
computations whatever the cut."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import thesis_like, write_rows
from test_real_recording import SCALE, _find

from imu_allan.analysis import diffscan, outliers
from imu_allan.analysis.store import MemoryStore, SpillStore, collect
from imu_allan.stats import kernels


def _oavar_definition(x: np.ndarray, m: int) -> float:
    """NIST SP 1065 eq. 11 from the phase, in Python integers (exact) for integer x."""
    X = np.concatenate(([0], np.cumsum(x.astype(object))))
    d = X[2 * m :] - 2 * X[m:-m] + X[: -2 * m]
    return float(sum(int(v) * int(v) for v in d)) / (2 * m * m * (x.size - 2 * m + 1))


def _pieces(x: np.ndarray, size: int):
    for a in range(0, x.shape[1], size):
        yield x[:, a : a + size]


@pytest.mark.parametrize("dtype", [np.uint16, np.float64])
def test_file_kernels_equal_the_memory_ones_bit_for_bit(dtype) -> None:
    rng = np.random.default_rng(3)
    n = 200_003
    x = 500 + np.cumsum(rng.normal(0, 0.05, (2, n)), axis=1) + rng.normal(0, 2, (2, n))
    x = np.rint(x).astype(np.uint16) if dtype is np.uint16 else x
    mem = MemoryStore(x)
    spill = collect(_pieces(x, 7777), [0, 1], 1000, "test", None, quiet=True)
    try:
        assert isinstance(spill, SpillStore) and spill.n == n
        for c in range(2):
            a, b = mem.octave(c), spill.octave(c)
            assert np.array_equal(a.oavar, b.oavar) and np.array_equal(a.avar, b.avar, equal_nan=True)
            assert a.ms[-1] == 1 << int(math.log2(n // 2))  # every octave up to n/2, stride 1
            if dtype is np.uint16:  # exact integer sums: the definition in integers, to the last rounding
                for k in (0, 5, a.ms.size - 1):
                    assert b.oavar[k, 0] == pytest.approx(_oavar_definition(x[c], int(a.ms[k])), rel=1e-15)
            assert np.array_equal(np.concatenate(list(spill.blocks(c, 1000))), x[c])
    finally:
        spill.close()
    assert not Path(spill.dir).exists()


def _spiky(n: int, quantized: bool) -> np.ndarray:
    rng = np.random.default_rng(11)
    x = rng.normal(0, 2.0, (3, n)) + np.cumsum(rng.normal(0, 0.02, (3, n)), axis=1)
    x[0, 1000] += 80  # a spike
    x[:, 5000:5040] += 60 * np.sin(np.arange(40) / 3)  # a burst on every channel
    x[1, n - 20000 :] += 50  # a step
    return np.rint(x + 500) if quantized else x


@pytest.mark.parametrize("quantized", [True, False])
def test_the_outlier_scan_by_pieces_is_the_scan_of_the_whole(quantized: bool) -> None:
    x = _spiky(60_000, quantized)
    whole = outliers.scan(x, 100.0)
    assert whole.count > 0 and any(e.step for e in whole.events)
    for size in (999, 4096, 60_000):
        st = MemoryStore(x)
        st.blocks = lambda c, size=size, st=st: (st.read(c, a, min(size, st.n - a)) for a in range(0, st.n, size))
        got = outliers.scan_store(st, 100.0)
        assert (diffscan._compiled(diffscan.of_store(st, 0)) is not None) == kernels.COMPILED
        assert got.events == whole.events
        for a, b in zip(got.channels, whole.channels):
            assert (a.scale, a.quantum, a.peak, a.core_ratio) == (b.scale, b.quantum, b.peak, b.core_ratio)
            assert np.array_equal(a.spans, b.spans) and np.array_equal(a.steps, b.steps)


@pytest.mark.parametrize("piece", [7, 1000, 1 << 16])
def test_first_look_by_pieces_takes_every_step_th_difference(piece: int) -> None:
    """The scan's first pass (compiled where built) on a store's pieces: the
    subsample d[::step] of the whole record's differences, and their max and min."""
    rng = np.random.default_rng(6)
    for n in (10, 1000, 100_001):
        x = np.rint(rng.normal(0, 3, (1, n)) + 500)
        s = collect(_pieces(x, piece), [0], 1 << 30, "t", None, quiet=True)
        d = np.diff(x[0])
        for keep in (3, 8, 16):
            sub, _, hi, lo = diffscan.first_look(diffscan.of_store(s, 0), n - 1, keep)
            assert np.array_equal(sub, d[:: max((n - 1) >> keep, 1)]) and (hi, lo) == (d.max(), d.min())


def test_exact_quantiles_by_windows_are_numpys() -> None:
    rng = np.random.default_rng(5)
    v = np.concatenate([rng.standard_normal(300_001), rng.standard_cauchy(1000) * 1e6, np.zeros(5000)])
    pieces = lambda: ((a, v[a : a + 65536]) for a in range(0, v.size, 65536))  # noqa: E731
    old = diffscan.COLLECT
    try:
        diffscan.COLLECT = 5000  # force the narrowing by histograms
        got = diffscan.quantiles(pieces, v.size, [0.5, 0.25, 0.999, 0.0, 1.0], lambda w: w)
    finally:
        diffscan.COLLECT = old
    np.testing.assert_allclose(got, np.quantile(v, [0.5, 0.25, 0.999, 0.0, 1.0]), rtol=1e-15, atol=0)


@pytest.mark.parametrize("dtype", [np.uint16, np.float64])
def test_warmup_windows_taken_from_the_octave_pass_are_each_windows_own(dtype) -> None:
    """The windows' overlapping AVAR that the record's octave pass notes on its way
    (store.windows, planned before it) against each window computed by itself, and
    against the definition in integers on a few windows, in memory and streamed."""
    from imu_allan.analysis import dynamic

    rng = np.random.default_rng(8)
    n = 150_001
    x = 500 + np.cumsum(rng.normal(0, 0.05, (2, n)), axis=1) + rng.normal(0, 2, (2, n))
    x = np.rint(x).astype(np.uint16) if dtype is np.uint16 else x
    starts, size, _ = dynamic.raw_windows(n, 100.0)
    alone = dynamic.from_store(MemoryStore(x), 100.0, ["a", "b"])  # no plan: a pass per window
    spill = collect(_pieces(x, 7777), [0, 1], 1000, "test", None, quiet=True)
    try:
        for store in (MemoryStore(x), spill):
            store.windows = (starts, size)
            ws = dynamic.from_store(store, 100.0, ["a", "b"])
            assert store.window_sums(1, starts, size) is not None and ws.var.shape == alone.var.shape
            np.testing.assert_allclose(ws.var, alone.var, rtol=1e-13)
            assert np.array_equal(ws.weight, alone.weight)
            if dtype is np.uint16:
                for w, k in ((0, 0), (7, 3), (len(starts) - 1, ws.ms.size - 1)):
                    seg = x[1, starts[w] : starts[w] + size]
                    assert ws.var[w, 1, k] == pytest.approx(_oavar_definition(seg, int(ws.ms[k])), rel=1e-15)
    finally:
        spill.close()


def _walk(a, b, path, diffs: list) -> None:
    if isinstance(a, dict):
        for k in a.keys() & b.keys():
            _walk(a[k], b[k], f"{path}/{k}", diffs)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (u, v) in enumerate(zip(a, b)):
            _walk(u, v, f"{path}[{i}]", diffs)
    elif a != b:
        diffs.append((path, a, b))


def _both(run_cli, path: Path, *args) -> tuple[dict, dict]:
    docs = []
    for extra in ((), ("--memory", "1")):
        rc, out, err = run_cli("analyze", path, "--json", *args, *extra)
        assert rc == 0, err
        docs.append(json.loads(out))
    return docs[0], docs[1]


def _same_but_held_curves(a: dict, b: dict) -> None:
    """Every number both documents report is equal; the streamed one lacks only
    the curves that need every sample in memory, and says it was streamed."""
    assert any("streamed" in s for s in b["notes"]) and not any("streamed" in s for s in a["notes"])
    a, b = json.loads(json.dumps(a)), json.loads(json.dumps(b))
    if "warmup" in b and b["warmup"].get("tested"):  # a streamed rows file's windows skip its temperature
        assert any("temperature not read" in s for s in b["warmup"]["notes"]) and b["warmup"]["temp_bins"] == []
        for d in (a, b):
            d["warmup"].pop("temp_bins"), d["warmup"].pop("notes")
    diffs: list = []
    _walk({k: v for k, v in a.items() if k != "notes"}, b, "", diffs)
    assert diffs == []
    for ch, c in a["channels"].items():
        assert set(c) == set(b["channels"][ch])
        assert set(c.get("curves", {})) - set(b["channels"][ch].get("curves", {})) <= {"mdev", "hdev"}


def test_streamed_analysis_of_a_generated_recording_is_the_in_memory_one(run_cli, tmp_path: Path) -> None:
    rows = thesis_like(40_000, 21)
    rows[7000, 3] = 1000  # a spike on gx: the outliers are replaced in both
    rows[20000:20030, :6] += 40
    path = write_rows(tmp_path / "rows.txt", np.clip(rows, 0, 1023))
    a, b = _both(run_cli, path, "--fs", "100")
    assert a["outliers"]["checked"] and a["channels"]["gx"]["outliers"]["count"] >= 1
    assert "signal" in b["channels"]["gx"]["model"]["fit_percent"]
    _same_but_held_curves(a, b)


def test_streamed_analysis_of_the_real_recording_is_the_in_memory_one(run_cli) -> None:
    path = _find()
    if path is None:
        pytest.skip("the real recording is absent (see test_real_recording.py)")
    a, b = _both(run_cli, path, "--fs", "100", "--scale", SCALE, "--no-warmup")
    assert a["source"]["n"] == 1_000_000
    _same_but_held_curves(a, b)


def test_progress_line_counts_rows_with_their_rate_and_the_time_left(monkeypatch, run_cli, tmp_path: Path) -> None:
    import io

    from imu_allan.render import progress as rp

    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    clock = [100.0]
    monkeypatch.setattr(rp.time, "monotonic", lambda: clock[0])
    tty = Tty()
    with rp.Progress("reading f", 10_000, stream=tty, delay=0.5, unit=" rows") as p:
        clock[0] = 102.0  # 2 s in, 2,500 rows: 1,250 rows/s, 7,500 left: 6 s
        p.update(2500)
        line = tty.getvalue()
    assert "25.0%" in line and "2,500 rows" in line and "1.25 k rows/s" in line and "6 s left" in line
    clock[0] = 103.0
    with rp.Progress("reading f", None, stream=tty, delay=0.5, unit=" rows") as p:
        clock[0] = 107.0  # no total known: the count and the rate, no ETA
        p.update(40_000)
        assert tty.getvalue().endswith("reading f 40,000 rows  10 k rows/s")
    rc, out, err = run_cli("analyze", write_rows(tmp_path / "r.txt", thesis_like(3000, 1)), "--fs", "100", "--quiet")
    assert rc == 0 and err == ""


def test_outliers_replaced_in_a_store_are_replace_of_the_array() -> None:
    """Every channel's own spans, in memory and in files (outliers.replace is the reference)."""
    x = _spiky(50_000, True)
    x[1, 20_000] += 90  # a spike on each other channel, at other times
    x[2, 31_000] -= 90
    found = outliers.scan(x, 100.0)
    assert all(ch.spans.size for ch in found.channels)  # every channel changed, each its own way
    ref = outliers.replace(x, found)
    for st in (MemoryStore(x), collect(_pieces(x, 12_345), [0, 1, 2], 1000, "t", None, quiet=True)):
        from imu_allan.analysis.store import replaced

        clean = replaced(st, found)
        try:
            for c in range(3):
                assert np.array_equal(np.concatenate(list(clean.blocks(c, 7000))), ref[c])
        finally:
            clean.close()
            st.close()
