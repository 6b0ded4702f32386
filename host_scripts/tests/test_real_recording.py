"""The noise terms of a real sensor: an ADIS16405 at rest for 2.78 h (1e6 sample
sets at 100 Hz; SMAC-Group/imudata, University of Calgary, CC BY-NC-SA 4.0).

The recording is not part of the project: it is read from the data folder
beside the repository (``<repo>/../shared/data``, or beside a folder further
up), or from $IMU_ALLAN_DATA (the file or its folder),
and the tests are skipped, saying so, only where it is absent."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

NAME = "adis16405_imu2_codes.tsv.gz"
SCALE = "gx=0.05,gy=0.05,gz=0.05,ax=0.00333g,ay=0.00333g,az=0.00333g"
REPO = Path(__file__).resolve().parents[2]
B_READOFF = math.sqrt(2 * math.log(2) / math.pi)  # 0.664, IEEE 952: ADEV of flicker of coefficient B
BASIS = {
    "Q": lambda t: 3 / t**2,
    "N": lambda t: 1 / t,
    "B": lambda t: B_READOFF**2 + 0 * t,
    "K": lambda t: t / 3,
    "R": lambda t: t**2 / 2,
}


def _find() -> Path | None:
    # <repo>/../shared/data, or the same beside any folder above (a worktree inside a checkout)
    candidates = [d / "shared" / "data" / NAME for d in REPO.parents]
    env = os.environ.get("IMU_ALLAN_DATA")
    if env:
        candidates.append(Path(env) / NAME if Path(env).is_dir() else Path(env))
    return next((p for p in candidates if p.is_file()), None)


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    src = _find()
    if src is None:
        pytest.skip(
            f"the real recording {NAME} is absent: looked in {REPO.parent / 'shared' / 'data'} and $IMU_ALLAN_DATA"
        )
    return src  # read as shipped, gzip and all, as a user's command line does


def _analyze(run_cli, path: Path, *extra: str) -> dict:
    rc, out, err = run_cli("analyze", path, "--fs", 100, "--scale", SCALE, "--no-model", "--json", *extra)
    assert rc == 0, err
    return json.loads(out)


@pytest.fixture(scope="module")
def doc(recording: Path) -> dict:
    import contextlib
    import io

    from imu_allan.cli.main import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        assert main(["analyze", str(recording), "--fs", "100", "--scale", SCALE, "--no-model", "--json"]) == 0
    return json.loads(buf.getvalue())


def _min_oadev(c: dict) -> float:
    return min(p["dev"] for p in c["curve"] if p["dev"])


def test_gyros_match_the_datasheet_and_the_curve(doc: dict) -> None:
    """ADIS16405: ARW 2 deg/sqrt(h) = 0.033 deg/sqrt(s), in-run bias stability 0.007 deg/s."""
    for ch in ("gx", "gy", "gz"):
        t = doc["channels"][ch]["terms"]
        assert t["N"] is not None and 0.030 <= t["N"]["value"] <= 0.046, (ch, t["N"])
        assert t["B"] is not None and 0.005 <= t["B"]["value"] <= 0.015, (ch, t["B"])


@pytest.fixture(scope="module")
def rows(recording: Path) -> np.ndarray:
    import gzip

    with gzip.open(recording, "rt") as f:
        return np.loadtxt(f, dtype=np.float64)


def _white_level(x: np.ndarray, fs: float) -> tuple[float, float]:
    """The low-frequency white level (as N, u sqrt(s)) read twice, independently of the
    fit: the Welch PSD's mean over 1-10 Hz (the mean of the periodogram's bins: their
    median is a chi-squared median, about 1 % under the level) and allantools' ADEV
    times sqrt(tau) on the flat -1/2 line (median of 0.04, 0.08, 0.16 s)."""
    import allantools
    from scipy import signal

    f, p = signal.welch(x - x.mean(), fs=fs, nperseg=1 << 16)
    psd_n = math.sqrt(np.mean(p[(f >= 1) & (f <= 10)]) / 2.0)  # one-sided 2 N^2
    t, ad, _, _ = allantools.oadev(x, rate=fs, data_type="freq", taus=np.array([0.04, 0.08, 0.16]))
    return psd_n, float(np.median(ad * np.sqrt(t)))


_AX_MODE = (
    "known gap: ax's mount resonance sits at 10.5 Hz, and the 1-10 Hz PSD this level reads is 5.8 % over the "
    "2-8 Hz one beside the mode (its ADEV sqrt(tau) wobbles 0.95-1.03 over 0.04-0.16 s: no flat -1/2 line); N, "
    "read under the resonance the fit keeps, is 1.7 % over the 2-8 Hz level and inside its interval "
    "(test_a_kept_resonance_is_identified_...), and its interval's top lies 0.07 % under this level"
)


@pytest.mark.parametrize(
    "i, ch", [pytest.param(0, "ax", marks=pytest.mark.xfail(strict=True, reason=_AX_MODE)), (1, "ay"), (2, "az")]
)
def test_accelerometers_velocity_random_walk(doc: dict, rows: np.ndarray, i: int, ch: str) -> None:
    """Datasheet VRW 0.2 m/s/sqrt(h) = 0.0033 m/s/sqrt(s) typical (a typical figure, not a
    limit: this unit's az sits at 0.0045 by its own PSD).  What the fit answers for is the
    unit's own white level: N within 5 % of it and the level inside N's 95 % interval."""
    c = doc["channels"][ch]
    n = c["terms"]["N"]
    assert n is not None and 0.0033 / 1.5 <= n["value"] <= 0.0033 * 1.5, (ch, n)
    psd_n, line_n = _white_level(rows[:, i] * c["scale_per_count"], 100.0)
    assert abs(psd_n / line_n - 1) < 0.03, (ch, psd_n, line_n)  # the two readings agree
    level = 0.5 * (psd_n + line_n)
    assert abs(n["value"] / level - 1) < 0.05, (ch, n, level)
    assert n["low"] <= level <= n["high"], (ch, n, level)


def test_a_kept_resonance_is_identified_and_N_under_it_holds_the_level_beside_the_mode(
    doc: dict, rows: np.ndarray
) -> None:
    """Where the fit keeps the accelerometers' mount resonance (8.6-10.6 Hz), the term has a
    value (not a bound: its variance is clear of 0) and N, read under it, holds the white
    level of the Welch PSD between the 0.5 Hz line's harmonics and the mode (2-8 Hz, flat
    within 3 % on these units): a quality the octave points cannot pin no longer trades
    N's interval wide (it was 15-32 %), and N's interval still holds that level."""
    from scipy import signal

    kept = 0
    for i, ch in enumerate(("ax", "ay", "az")):
        c = doc["channels"][ch]
        if "Resonance" not in c["fit"]["model"]:
            continue
        kept += 1
        res, n = c["terms"]["RES"], c["terms"]["N"]
        assert res is not None and res["low"] > 0, (ch, res)
        x = rows[:, i] * c["scale_per_count"]
        f, p = signal.welch(x - x.mean(), fs=100.0, nperseg=1 << 16)
        level = math.sqrt(np.mean(p[(f >= 2) & (f <= 8)]) / 2.0)
        assert n["low"] <= level <= n["high"], (ch, n, level)
        assert n["high"] / n["low"] < 1.10, (ch, n)  # not traded wide by the unpinned quality
    assert kept >= 1  # the mode is found on this unit (x and y axes)


def test_b_is_reported_and_sits_on_the_curves_floor(doc: dict) -> None:
    for ch, c in doc["channels"].items():
        b = c["terms"]["B"]
        assert b is not None, (ch, c["term_notes"].get("B"))
        floor = _min_oadev(c) / B_READOFF  # the thesis' read-off, from the curve itself
        assert 0.4 <= b["value"] / floor <= 1.2, (ch, b["value"], floor)
        assert b["low"] <= b["value"] <= b["high"]
        lo, hi = b["tau_range_s"]
        assert 1 <= lo < hi  # a flat region, well past the white noise


def test_no_term_line_or_bound_above_the_curve(doc: dict) -> None:
    """Every value and the upper bound of every term left out, drawn as its term's line, stays under
    the curve's own 95 % interval, outside the regions the document names: the short taus the
    sensor's filter pulls below the white-noise line, and the dips it reports as unexplained."""
    for ch, c in doc["channels"].items():
        short = [r["tau_s"][1] for r in c["fit"]["unexplained"] if r["kind"] == "short-tau correlation"]
        if c["terms"].get("LP"):  # the fitted band limit names the taus it bends under N's line
            short.insert(0, c["terms"]["LP"]["tau_range_s"][1])
        dips = [r["tau_s"] for r in c["fit"]["unexplained"] if r["kind"] == "dip"]
        pts = [
            p
            for p in c["curve"]
            if p["dev"]
            and not (short and p["tau_s"] <= short[0])
            and not any(lo <= p["tau_s"] <= hi for lo, hi in dips)
        ]
        tau = np.array([p["tau_s"] for p in pts])
        high = np.array([p["high"] for p in pts]) ** 2
        for k, f in BASIS.items():
            t = c["terms"][k]
            ub = c["upper_bounds"][k]
            assert ub is not None and math.isfinite(ub), (ch, k, c["term_notes"].get(k))
            # the value, and the bound of a term left out (an interval's top is not capped by the curve)
            for v in [t["value"]] if t else [ub]:
                # within the curve's interval widened by the model error the fit may grant (5 %)
                assert np.all(v * v * f(tau) <= high * 1.05**2), (ch, k, v)


def test_unexplained_ranges_are_named(doc: dict) -> None:
    for ch, c in doc["channels"].items():
        fit = c["fit"]
        assert fit["chi2_dof"] < 10, (ch, fit["chi2_dof"])
        assert len(fit["unexplained"]) == sum(n.startswith("not explained") for n in fit["notes"])
    # the accelerometers' hump near 0.5 s (an oscillation of about 0.7 Hz; visible in the raw curve)
    for ch in ("ax", "ay", "az"):
        kinds = [(r["kind"], r["tau_s"]) for r in doc["channels"][ch]["fit"]["unexplained"]]
        sine = doc["channels"][ch]["terms"].get("SIN")  # or fitted as a sinusoid of that period
        assert any(k in ("hump", "oscillation") and lo <= 0.64 <= hi for k, (lo, hi) in kinds) or (
            sine is not None and 1.5 < 1 / sine["f0_hz"] < 2.0
        ), (ch, kinds, sine)


def test_the_grid_does_not_move_the_terms(recording: Path, run_cli, doc: dict) -> None:
    log = _analyze(run_cli, recording, "--taus", "log", "--channels", "ax,gz")
    assert log["options"]["taus"] == "log"
    for ch in ("ax", "gz"):
        a, b = doc["channels"][ch], log["channels"][ch]
        assert len(b["curve"]) > len(a["curve"])
        for k in ("N", "B", "K"):
            ta, tb = a["terms"][k], b["terms"][k]
            assert (ta is None) == (tb is None), (ch, k)
            if ta:
                assert tb["low"] <= ta["value"] <= tb["high"] and ta["low"] <= tb["value"] <= ta["high"]
