"""The recording-time advice (advice.py) checked by recording the time it advises.

For each seed: a record of T0 from a sensor made by an independent generator
written here from the textbook formulas (Gaussian white noise, a cumulative sum
for the rate random walk K, Kasdin's fractional differencing for flicker B), the
advice for the term at +-10 %, then a FRESH record of the advised length and the
interval ``analyze`` then gives the term. The advice is an estimate under the
fitted model; it is graded here on the records whose fit is the generator's
model (the same terms, and an interval that the points' EDFs explain, i.e. no
model error granted): there K's must be within +-10 % of the target (9 % to
11 %) in at least 80 % of the seeds. The records where the fit departs from the
generator's model are counted and printed (docs/dynamic.md, section 4, gives
the figures and why); they must stay a minority. B is graded more loosely
(TOLERANCE says why).

IMU_ALLAN_ADVICE_SEEDS sets the number of seeds (default 10; the figures in the
docs are from 40)."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from scipy import signal

from imu_allan.analysis import advice
from imu_allan.analysis.pipeline import Options, analyze
from imu_allan.profiles import build_profile
from imu_allan.sources.detect import SampleSource, Source

FS = 10.0
T0 = 3000.0
SEEDS = int(os.environ.get("IMU_ALLAN_ADVICE_SEEDS", "10"))
SENSORS = {
    # white noise N and a rate random walk K crossing at sqrt(3) N / K = 52 s
    "K": dict(n_=0.3, b=0.0, k=0.01),
    # white noise N and flicker B: 0.664 B meets N / sqrt(tau) near 20 s
    "B": dict(n_=0.3, b=0.1, k=0.0),
}


def _sensor(n: int, seed: int, n_: float, b: float, k: float) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n) * n_ * math.sqrt(FS)
    if b:
        j = np.arange(1, n)
        h = np.concatenate(([1.0], np.cumprod((j - 1 + 0.5) / j)))
        x += signal.fftconvolve(rng.standard_normal(n) * b, h)[:n]
    if k:
        x += np.cumsum(rng.standard_normal(n) * k / math.sqrt(FS))
    return x


def _analysis(x: np.ndarray) -> dict:
    ss = SampleSource("csv", "generated", ["gx"], lambda: iter([x[None, :]]), False, fs=FS)
    res = analyze(
        Source("generated", ss, None),
        build_profile(None, {"gx": (1.0, "deg/s")}),
        Options(fs=FS, model=False, extra_curves=False),
    )
    advice.add_to_analysis(res.doc, fits=res.fits)
    return res.doc["channels"]["gx"]


def _departs(ch: dict, sensor: dict, term: str) -> bool:
    """The fit departs from the generator's model: one of its terms is not identified,
    or the graded term's interval is not what its points' EDFs give (model error granted)."""
    want = {"N"} | ({"B"} if sensor["b"] else set()) | ({"K"} if sensor["k"] else set())
    if any(ch["terms"].get(k) is None for k in want):
        return True
    t = ch["terms"][term]
    return t["interval_pct"] > advice.MODEL_ERROR_RATIO * t["expected_pct"]


TOLERANCE = {"K": 0.10, "B": 0.30}
"""Relative distance from the target accepted in 80 % of the graded seeds. K meets the
+-10 % asked (measured: 31 of 38 seeds). B cannot, by any advice: beside white noise,
B's interval moves 3 to 5 times as fast as its estimate (an estimate 11 % low has an
interval 30 % wider, 17 % low 80 % wider), so the sampling error of B at T0 moves the advised time and that of
the fresh record moves the interval it gets (measured: 21 of 39 within +-10 %, 31 of 36
graded within +-30 %; docs/dynamic.md, section 4)."""


@pytest.mark.parametrize("term", sorted(SENSORS))
def test_recording_the_advised_time_gives_the_target_interval(term: str) -> None:
    sensor = SENSORS[term]
    graded, departed, skipped = [], [], 0
    for seed in range(SEEDS):
        first = _analysis(_sensor(int(T0 * FS), seed, **sensor))
        t = first["terms"][term]
        if t is None or t["record_s_for_10pct"] is None:
            skipped += 1  # no term to advise on after T0
            continue
        advised = t["record_s_for_10pct"]
        assert advised > T0  # +-10 % is not reached after T0 on these sensors
        second = _analysis(_sensor(int(round(advised * FS)), 1000 + seed, **sensor))
        t2 = second["terms"][term]
        (departed if _departs(second, sensor, term) else graded).append(t2["interval_pct"] if t2 else math.inf)
    g = np.array(graded)
    near = np.abs(g / 10.0 - 1) <= TOLERANCE[term] + 1e-9
    strict = np.abs(g / 10.0 - 1) <= 0.1 + 1e-9
    print(
        f"\n{term}: +-% at the advised time, graded {np.round(np.sort(g), 1).tolist()}, "
        f"fit departs {np.round(np.sort(departed), 1).tolist()}, no term after T0 {skipped}; "
        f"within +-10 % of the target {strict.sum()}/{g.size} graded, "
        f"{strict.sum()}/{SEEDS - skipped} of all"
    )
    assert skipped <= SEEDS // 5
    assert g.size >= 0.6 * (SEEDS - skipped)
    assert 9.0 <= np.median(g) <= 11.0
    assert near.sum() >= 0.8 * g.size
