"""Spikes and bursts found before the statistics (outliers.py and its use by
``analyze``): found where they were put, nothing found where there are none,
left out of N and B by default and kept with ``--outliers keep``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import report_lines, thesis_like, write_rows
from test_real_recording import NAME, REPO, _find

from imu_allan.analysis import outliers
from imu_allan.analysis.pipeline import Options, analyze
from imu_allan.channels import CHANNELS
from imu_allan.profiles import build_profile
from imu_allan.sources.detect import SampleSource, Source, load

FS = 100.0


def _analyze(data: np.ndarray, mode: str = "replace", name: str = "memory") -> dict:
    """``analyze`` of (6, n) codes held in memory (counts, no model)."""
    src = Source(
        name, SampleSource("rows", name, list(CHANNELS), lambda: iter([data]), True, fs=FS, n_hint=data.shape[1]), None
    )
    return analyze(
        src, build_profile("counts", {}, None), Options(fs=FS, model=False, extra_curves=False, outliers=mode)
    ).doc


def _quiet(n: int, seed: int, sd: tuple[float, ...] = (1.0, 1.2, 1.5, 6.0, 6.5, 7.5)) -> np.ndarray:
    """Six channels of white noise rounded to codes around 512 (an ADC at rest)."""
    rng = np.random.default_rng(seed)
    return np.rint(512 + np.array(sd)[:, None] * rng.standard_normal((6, n)))


def _mad_sigma(d: np.ndarray) -> float:
    """Robust sigma of differences, written here from its definition (unrounded data)."""
    return 1.4826 * float(np.median(np.abs(d - np.median(d))))


# ---- the real recording ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def real() -> np.ndarray:
    path = _find()
    if path is None:
        pytest.skip(
            f"the real recording {NAME} is absent: looked in {REPO.parent / 'shared' / 'data'} and $IMU_ALLAN_DATA"
        )
    blocks = list(load(str(path)).samples.open_blocks())
    return np.concatenate(blocks, axis=1)[:6].astype(np.float64)


@pytest.fixture(scope="module")
def clean_doc(real: np.ndarray) -> dict:
    return _analyze(real)


@pytest.fixture(scope="module")
def spiked(real: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The recording with 100 single-sample spikes, 20 to 45 times each channel's
    sample-to-sample spread, at random times and channels, kept inside 1..1022."""
    rng = np.random.default_rng(19)
    n = real.shape[1]
    where = np.sort(rng.choice(np.arange(5, n - 5, 10), 100, replace=False))  # 10 samples apart at least
    chan = rng.integers(0, 6, where.size)
    spread = np.array([np.std(np.diff(real[c])) for c in range(6)])
    amp = np.rint(rng.uniform(20, 45, where.size) * spread[chan])  # codes are whole numbers
    up = real[chan, where] + amp <= 1022
    x = real.copy()
    x[chan, where] += np.where(up, amp, -amp)
    assert x.min() >= 1 and x.max() <= 1022
    return x, where, chan


def test_nothing_is_flagged_on_the_clean_real_recording(clean_doc: dict) -> None:
    assert clean_doc["outliers"]["checked"] and clean_doc["outliers"]["events"] == []
    for ch, c in clean_doc["channels"].items():
        assert c["outliers"]["count"] == 0 and c["outliers"]["times_s"] == [], ch
        assert c["outliers"]["steps_s"] == [], ch
    assert not any("outlier" in n for n in clean_doc["notes"] if "not checked" not in n)


def test_hundred_spikes_in_the_real_recording_are_all_found_and_n_b_stay_within_3_percent(
    spiked: tuple[np.ndarray, np.ndarray, np.ndarray], clean_doc: dict
) -> None:
    x, where, chan = spiked
    doc = _analyze(x)
    for c, ch in enumerate(CHANNELS):
        o = doc["channels"][ch]["outliers"]
        mine = where[chan == c]
        assert o["count"] == mine.size, (ch, o["count"], mine.size)
        assert o["times_s"] == pytest.approx(list(mine / FS)), ch
        for k in ("N", "B"):
            clean = clean_doc["channels"][ch]["terms"][k]
            got = doc["channels"][ch]["terms"][k]
            if clean is None:
                assert got is None, (ch, k)
                continue
            assert got["value"] == pytest.approx(clean["value"], rel=0.03), (ch, k)
    assert len(doc["outliers"]["events"]) == 100
    assert all(e["kind"] == "spike" for e in doc["outliers"]["events"])
    # the effect reported: N without them is the one shown; with them in, higher
    # (about 17 spikes of ~32 spreads per channel: +3.5 % on the variance at tau0;
    # the whole-curve fit reads these unfiltered spikes as white noise above the
    # part's band limit too, so N moves by a few per cent more than tau0 alone says)
    for ch in CHANNELS:
        n_eff = doc["channels"][ch]["outliers"]["effect"]["N"]
        assert n_eff["without_outliers"] == doc["channels"][ch]["terms"]["N"]["value"]
        assert 0.5 < n_eff["change_pct"] < 10, (ch, n_eff)


# ---- no false alarms ------------------------------------------------------------------------


def test_nothing_is_flagged_on_ten_million_gaussian_samples() -> None:
    """Designed for at most 1e-10 false alarms per difference: here 1e7 - 1 differences."""
    x = np.random.default_rng(7).standard_normal(10_000_000)
    found = outliers.scan(x[None, :], FS)
    assert found.count == 0 and found.events == []
    # the scale is the differences' standard deviation, sqrt(2) for unit white noise
    assert found.channels[0].scale == pytest.approx(math.sqrt(2), rel=0.01)
    assert math.erfc(outliers.SPIKE_SIGMA / math.sqrt(2)) < 1e-10


@pytest.mark.parametrize("sd", [0.2, 0.45, 0.8, 1.5, 3.0])
def test_quantized_noise_gets_its_true_scale_and_no_flag(sd: float) -> None:
    """Codes whose differences are mostly 0 or +-1: the plain MAD would read 0 or
    1 code; the grouped median reads the spread the unrounded noise has."""
    rng = np.random.default_rng(int(sd * 100))
    x = np.rint(500 + sd * rng.standard_normal(1_000_000))
    found = outliers.scan(x[None, :], FS)
    assert found.count == 0 and found.events == []
    if sd >= 0.45:  # the differences' plain standard deviation (no outlier here to spoil it)
        assert found.channels[0].scale == pytest.approx(np.std(np.diff(x)), rel=0.15), sd
    assert found.channels[0].scale >= 0.5  # never below half a step


def test_a_constant_channel_has_nothing_to_flag() -> None:
    found = outliers.scan(np.full((1, 1000), 300.0), FS)
    assert found.count == 0 and found.channels[0].scale == 0


# ---- bursts, impulsive noise, steps ---------------------------------------------------------------


def test_a_knock_on_the_bench_is_one_event_with_its_time(tmp_path: Path, run_cli) -> None:
    """A damped oscillation (12 Hz, decaying in 0.25 s, a second long) on every axis."""
    n, t0 = 60_000, 31_234
    x = _quiet(n, 3)
    t = np.arange(100) / FS
    for c in range(6):
        x[c, t0 : t0 + 100] += np.rint(80 * (1 + c) * np.exp(-t / 0.25) * np.sin(2 * np.pi * 12 * t + c))
    rows = np.vstack([x, np.full((1, n), 300)]).T.astype(int)
    rc, out, err = run_cli(
        "analyze", write_rows(tmp_path / "knock.txt", rows), "--fs", 100, "--json", "--no-model", "--profile", "counts"
    )
    assert rc == 0, err
    doc = json.loads(out)
    ev = doc["outliers"]["events"]
    assert len(ev) == 1, ev
    assert ev[0]["start_s"] == pytest.approx(t0 / FS, abs=1.5 / FS)
    assert ev[0]["kind"] == "burst" and ev[0]["channels"] == list(CHANNELS)
    assert 0.1 <= ev[0]["duration_s"] <= 1.0
    for ch in CHANNELS:
        assert doc["channels"][ch]["outliers"]["times_s"] == [ev[0]["start_s"]], ch


def test_a_knock_is_said_next_to_the_numbers(tmp_path: Path, run_cli) -> None:
    n, t0 = 30_000, 12_000
    x = _quiet(n, 4)
    t = np.arange(100) / FS
    sd = np.array([1.0, 1.2, 1.5, 6.0, 6.5, 7.5])[:, None]
    x[:, t0 : t0 + 100] += np.rint(60 * sd * np.exp(-t / 0.25) * np.sin(2 * np.pi * 9 * t))
    rows = np.vstack([x, np.full((1, n), 300)]).T.astype(int)
    rc, out, err = run_cli(
        "analyze", write_rows(tmp_path / "knock.txt", rows), "--fs", 100, "--no-model", "--profile", "counts"
    )
    assert rc == 0, err
    block = out.split("\ngx [count]\n")[1].split("\n\n")[0]
    said = block.split("outliers:")[1].split("  N random walk")[0]  # before the terms
    assert " at 120.0" in said and "replaced" in said, said
    assert "with them in, N " in said, said


def test_impulsive_noise_gets_its_outliers_counted() -> None:
    """White noise plus sparse Laplacian impulses (kurtosis about 100, like a real
    gyro's impulsive noise): the impulses above the threshold are counted, those
    well above it every one, nothing else."""
    rng = np.random.default_rng(11)
    n, p, b = 1_000_000, 5e-5, 17.0
    x = rng.standard_normal(n)
    where = np.flatnonzero(rng.random(n) < p)
    where = where[(where > 0) & (where < n - 1)]
    amp = rng.laplace(0, b, where.size)
    x[where] += amp
    kurt = float(np.mean((x - x.mean()) ** 4) / np.var(x) ** 2)
    assert 50 < kurt < 250, kurt
    found = outliers.scan(x[None, :], FS)
    thr = outliers.SPIKE_SIGMA * _mad_sigma(np.diff(x))  # |A| beyond it +- the noise: found
    sure = set(where[np.abs(amp) > thr + 5 * math.sqrt(2)].tolist())
    maybe = set(where[np.abs(amp) > thr - 5 * math.sqrt(2)].tolist())
    flagged = set()
    for s, t in found.channels[0].spans:
        flagged.update(range(int(s), int(t)))
    assert sure <= flagged <= maybe, (len(sure), len(flagged), len(maybe))
    assert found.count >= 0.3 * where.size


def test_a_lone_jump_is_a_level_shift_kept_not_a_spike() -> None:
    x = _quiet(20_000, 5)[:1]
    x[0, 9000:] += 200
    found = outliers.scan(x, FS)
    assert found.count == 0
    assert [e.start for e in found.events] == [9000] and found.events[0].step
    assert np.array_equal(outliers.replace(x, found), x)


def test_replaced_samples_lie_on_the_line_between_their_neighbours() -> None:
    x = _quiet(5000, 6)[:1]
    x[0, 1000:1004] += [300, -250, 280, -300]  # a short burst of four wild samples
    x[0, 3000] += 400
    found = outliers.scan(x, FS)
    assert found.channels[0].spans.tolist() == [[1000, 1004], [3000, 3001]]
    y = outliers.replace(x, found)
    assert np.allclose(y[0, 999:1005], np.linspace(x[0, 999], x[0, 1004], 6))
    assert y[0, 3000] == pytest.approx((x[0, 2999] + x[0, 3001]) / 2)
    untouched = np.ones(5000, dtype=bool)
    untouched[[1000, 1001, 1002, 1003, 3000]] = False
    assert np.array_equal(y[0, untouched], x[0, untouched])


# ---- mostly spikes, and --outliers keep -----------------------------------------------------------


@pytest.mark.parametrize("fraction", [0.3, 0.5])
def test_a_recording_that_is_mostly_spikes_is_refused_in_one_line(tmp_path: Path, run_cli, fraction: float) -> None:
    n = 20_000
    rng = np.random.default_rng(8)
    x = _quiet(n, 8)
    hit = rng.random(n) < fraction
    x[3, hit] += rng.choice([-1, 1], hit.sum()) * rng.uniform(150, 400, hit.sum())
    rows = np.clip(np.vstack([x, np.full((1, n), 300)]).T, 1, 1022).astype(int)
    path = write_rows(tmp_path / "spiky.txt", rows)
    rc, out, err = run_cli("analyze", path, "--fs", 100, "--no-model")
    assert rc == 2 and out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    assert str(path) in err and "gx" in err and "refused" in err
    rc, out, err = run_cli("analyze", path, "--fs", 100, "--no-model", "--json", "--outliers", "keep")
    assert rc == 0, err


def test_outliers_keep_keeps_them_and_n_moves_by_them() -> None:
    x = _quiet(200_000, 9)
    rng = np.random.default_rng(9)
    where = np.sort(rng.choice(np.arange(5, x.shape[1] - 5, 10), 40, replace=False))
    raw = x.copy()
    raw[4, where] += rng.choice([-1, 1], where.size) * 300
    clean = _analyze(x)
    kept, replaced = _analyze(raw, "keep"), _analyze(raw, "replace")
    n_clean = clean["channels"]["gy"]["terms"]["N"]["value"]
    n_kept = kept["channels"]["gy"]["terms"]["N"]["value"]
    n_repl = replaced["channels"]["gy"]["terms"]["N"]["value"]
    # 40 spikes of 300 codes in 2e5 samples of sd 6.5: the variance at tau0 grows by
    # 40 * 300^2 / 2e5 / 6.5^2 = 43 %: N (the -1/2 line through it) rises too
    assert n_kept > 1.1 * n_clean
    assert n_repl == pytest.approx(n_clean, rel=0.01)
    o = kept["channels"]["gy"]["outliers"]
    assert o["mode"] == "keep" and o["count"] == 40
    assert o["times_s"] == pytest.approx(list(where / FS))
    assert o["effect"]["N"]["with_outliers"] == n_kept
    assert o["effect"]["N"]["without_outliers"] == pytest.approx(n_repl)
    assert kept["channels"]["gx"]["outliers"]["count"] == 0


def test_thermal_finds_a_knock_before_its_regression(tmp_path: Path, run_cli) -> None:
    """A thermal cycle with a knock in it: one event, replaced before the
    bias-against-temperature regression, which still holds the true tempco."""
    from imu_allan.analysis import thermal

    fs, n, t0 = 50.0, 50 * 600, 50 * 350
    rng = np.random.default_rng(12)
    temp = np.rint(300 + 20 * np.sin(2 * np.pi * np.arange(n) / (fs * 300)))
    x = 512 + 2.0 * rng.standard_normal((6, n)) + 0.15 * (temp - 300)
    t = np.arange(50) / fs
    x[:, t0 : t0 + 50] += 150 * np.exp(-t / 0.25) * np.sin(2 * np.pi * 7 * t + 1)
    rows = np.vstack([np.rint(x), temp]).T.astype(int)
    path = write_rows(tmp_path / "cycle.txt", rows)
    doc = thermal.study(str(path), fs=fs, segments=1)
    assert doc["outliers"]["mode"] == "replace"
    assert doc["outliers"]["times_s"] == pytest.approx([t0 / fs], abs=1.5 / fs)
    assert all(doc["outliers"]["count"][ch] > 0 for ch in CHANNELS)
    tc = doc["channels"]["gx"]["tempco"]
    assert tc["low"] <= 0.15 <= tc["high"], tc
    rc, out, err = run_cli("thermal", path, "--fs", 50, "--segments", 1, "--outliers", "keep", "--json")
    assert rc == 0, err
    kept = json.loads(out)
    assert kept["outliers"]["mode"] == "keep" and kept["outliers"]["count"] == doc["outliers"]["count"]
    assert any("kept" in note for note in kept["notes"])


def test_a_device_log_alone_says_outliers_were_not_checked_and_a_streamed_file_is_checked(
    tmp_path: Path, run_cli
) -> None:
    """A device log alone (no samples): not checked; a file streamed past --memory
    is scanned piece by piece, with the in-memory result."""
    rows = thesis_like(4096, 2)
    log = tmp_path / "device.log"
    log.write_bytes(b"".join(report_lines(rows, 12)))
    rc, out, err = run_cli("analyze", log, "--json", "--no-model")
    assert rc == 0, err
    doc = json.loads(out)
    assert doc["outliers"]["checked"] is False
    assert doc["channels"]["gx"]["outliers"] == {"checked": False, "count": None, "times_s": []}
    rows = thesis_like(30_000, 3)
    rows[12_345, 4] = 1000
    big = write_rows(tmp_path / "big.txt", rows)  # 1.4 MB of float64 samples
    docs = []
    for extra in ((), ("--memory", 1)):
        rc, out, err = run_cli("analyze", big, "--fs", 100, "--json", "--no-model", *extra)
        assert rc == 0, err
        docs.append(json.loads(out))
    held, streamed = docs
    assert streamed["channels"]["gy"]["outliers"]["checked"] is True
    assert streamed["channels"]["gy"]["outliers"]["times_s"] == [12_345 / 100]
    assert streamed["outliers"] == held["outliers"]


def _band_limited(rng: np.random.Generator, n: int, fs: float, fc: float) -> np.ndarray:
    """White noise through a one-pole RC low-pass (y = a y + (1 - a) x, a = exp(-2 pi fc / fs))."""
    from scipy.signal import lfilter

    a = math.exp(-2 * math.pi * fc / fs)
    return lfilter([1 - a], [1, -a], rng.standard_normal(n))


def test_a_knock_at_1_khz_is_replaced_on_every_axis_it_shook_and_only_there() -> None:
    """At 1 kHz a knock's 15 Hz swings, 100 sample sd high, move a difference of
    a wide-band channel (fc 250 Hz) by at most 7.5 of its sd: under the spike
    threshold, so only the band-limited channels (fc 10 Hz: 27 sd) flag it; the
    burst test then finds it on the wide-band ones too. A channel the knock did not
    reach is left alone. Knock and span are the ones put in here."""
    fs, n = 1000.0, 1 << 19
    rng = np.random.default_rng(21)
    fcs = [10.0, 250.0, 250.0, 50.0, 10.0, 250.0]
    x = np.stack([_band_limited(rng, n, fs, fc) for fc in fcs])
    x /= x.std(axis=1, keepdims=True)
    t0, length = 300_000, 1200
    tt = np.arange(length) / fs
    knock = 100 * np.exp(-tt / 0.3) * np.sin(2 * np.pi * 15 * tt)
    y = x.copy()
    y[:5, t0 : t0 + length] += knock  # the last channel is not reached
    assert outliers.scan(x, fs).count == 0
    found = outliers.scan(y, fs)
    near = [e for e in found.events if abs(e.start - t0) < fs]
    assert len(near) == 1 and abs(near[0].start - t0) <= 5
    assert near[0].channels == (0, 1, 2, 3, 4)
    for c in range(5):  # the knock's loud part, its first 0.3 s, is replaced on each
        sp = found.channels[c].spans
        assert ((sp[:, 0] <= t0 + 5) & (sp[:, 1] >= t0 + 300)).any()
    assert found.channels[5].count == 0
