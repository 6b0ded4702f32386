"""The recording-time advice (advice.py) checked by recording the time it advises.

For each seed: a record of T0 from a sensor made by an independent generator
written here from the textbook formulas (Gaussian white noise, a cumulative sum
for the rate random walk K, Kasdin's fractional differencing for flicker B), then
the advice for the term at +-10 % followed exactly as a user does: the advice
says how much MORE to record (each process draws from its own stream, so a
longer record of a seed starts with the shorter one); a rough time (the term now
over advice.ROUGH_RATIO times the target) comes with a check
(``recheck_s_for_10pct``): record to it, analyse, ask again; a firm time: record
to it, and the interval ``analyze`` then gives the term is graded. Every seed is
graded: one without the term after T0 (no advice to follow), or whose fit on the
way takes another structure, counts as it comes out (no term: a miss). Each
seed's steps are printed (pytest -s).

The records start with the term at about +-13 %, 1.3 times the target, by
default, or farther (IMU_ALLAN_ADVICE_T0). The test asserts that the share
within +-10 % of the target (9 % to 11 %) over all seeds is not below 80 %
beyond chance (a one-sided binomial test at 5 %: 8 seeds cannot show a share to
better than +-15 %), that the interval graded is 10 % in the median, and that
few seeds lack the term after T0. The share itself, over 40 seeds from both
starts, is in docs/dynamic.md, section 4.

IMU_ALLAN_ADVICE_SEEDS sets the number of seeds (default 8, for make test; the
figures in docs/dynamic.md, section 4, are from 40), IMU_ALLAN_ADVICE_T0 the first
record's length, IMU_ALLAN_ADVICE_SEED0 the first seed (default 0; another set of
seeds checks figures chosen on the first)."""

from __future__ import annotations

import math
import os
import re

import numpy as np
import pytest
from scipy import signal
from scipy import stats as sps

from imu_allan.analysis import advice
from imu_allan.analysis.pipeline import Options, analyze
from imu_allan.profiles import build_profile
from imu_allan.sources.detect import SampleSource, Source

FS = 10.0
SEEDS = int(os.environ.get("IMU_ALLAN_ADVICE_SEEDS", "8"))
SEED0 = int(os.environ.get("IMU_ALLAN_ADVICE_SEED0", "0"))
SENSORS = {
    # white noise N and a rate random walk K crossing at sqrt(3) N / K = 52 s
    "K": dict(n_=0.3, b=0.0, k=0.01),
    # white noise N and flicker B: 0.664 B meets N / sqrt(tau) near 20 s
    "B": dict(n_=0.3, b=0.1, k=0.0),
}
T0 = {"K": 16000.0, "B": 4500.0}
"""The first record (s): the term at about +-13 % in the median (K: +-33 % after 3000 s).
IMU_ALLAN_ADVICE_T0 (s) sets both, for the figures from farther in docs/dynamic.md."""
if os.environ.get("IMU_ALLAN_ADVICE_T0"):
    T0 = dict.fromkeys(T0, float(os.environ["IMU_ALLAN_ADVICE_T0"]))


def _sensor(n: int, seed: int, n_: float, b: float, k: float) -> np.ndarray:
    """n samples; each process from its own stream of the seed (a longer record continues a shorter one)."""
    x = np.random.default_rng([seed, 0]).standard_normal(n) * n_ * math.sqrt(FS)
    if b:
        j = np.arange(1, n)
        h = np.concatenate(([1.0], np.cumprod((j - 1 + 0.5) / j)))
        x += signal.fftconvolve(np.random.default_rng([seed, 1]).standard_normal(n) * b, h)[:n]
    if k:
        x += np.cumsum(np.random.default_rng([seed, 2]).standard_normal(n) * k / math.sqrt(FS))
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
    """The fit departs from the generator's model: its processes are not the generator's
    (one missing, or one more: a Gauss-Markov process, a band limit), the graded term
    is not identified, or its interval is not what its points' EDFs give (model error granted)."""
    want = {"WN"} | ({"Flicker"} if sensor["b"] else set()) | ({"RW"} if sensor["k"] else set())
    if set(re.findall(r"(\w+)\(", ch["fit"]["model"])) != want:  # the processes fitted, named
        return True
    t = ch["terms"][term]
    return t is None or t["interval_pct"] > advice.MODEL_ERROR_RATIO * t["expected_pct"]


def test_a_longer_record_of_a_seed_continues_the_shorter() -> None:
    short, long_ = _sensor(3000, 7, 0.3, 0.1, 0.01), _sensor(7001, 7, 0.3, 0.1, 0.01)
    assert np.allclose(long_[:3000], short, rtol=0, atol=1e-12)


def _procs(ch: dict) -> str:
    return "+".join(re.findall(r"(\w+)\(", ch["fit"]["model"]))


MAX_ASKS = 6
"""A user who asks more than this many times is graded a miss (the checks never converged)."""


def _follow(seed: int, sensor: dict, term: str, t0: float) -> tuple[float, str, bool, bool]:
    """The staged advice followed as a user does: analyse the record; a term within the target
    is done; a rough time comes with a check (recheck_s_for_10pct): record to it and ask
    again; a firm time (no check): record to it, and that record is graded. Returns the
    interval graded, the seed's row, whether the first record lacked the term, and whether
    every fit on the way had the generator's model."""
    length, steps, clean = t0, [], True
    for _ in range(MAX_ASKS):
        ch = _analysis(_sensor(int(round(length * FS)), seed, **sensor))
        clean = clean and not _departs(ch, sensor, term)
        t = ch["terms"][term]
        if t is None or t["record_s_for_10pct"] is None:
            why = "no " + term if t is None else "not by recording longer"
            steps.append(f"{why} after {length:.0f} s ({_procs(ch)})")
            return math.inf, "; ".join(steps), not steps[:-1], False
        steps.append(f"+-{t['interval_pct']:.1f} % after {length:.0f} s ({_procs(ch)})")
        if t["interval_pct"] <= 10.0:  # the target reached: nothing more to record
            return t["interval_pct"], "; ".join(steps), False, clean
        check, final = t["recheck_s_for_10pct"], t["record_s_for_10pct"]
        if check is None and final <= length:  # no time more to record (the text gives none): done
            return t["interval_pct"], "; ".join(steps) + "; no more advised", False, clean
        length = check if check is not None else final
        if check is None:
            last = _analysis(_sensor(int(round(length * FS)), seed, **sensor))
            t2, clean = last["terms"][term], clean and not _departs(last, sensor, term)
            got = t2["interval_pct"] if t2 else math.inf
            steps.append(f"advised {length:.0f} s: +-{got:.2f} % ({_procs(last)})")
            return got, "; ".join(steps), False, clean
    return math.inf, "; ".join(steps) + "; asked too often", False, False


@pytest.mark.parametrize("term", sorted(SENSORS))
def test_recording_the_advised_time_gives_the_target_interval(term: str) -> None:
    sensor, t0 = SENSORS[term], T0[term]
    got, rows, missing, clean, clean_near = [], [], 0, 0, 0
    for seed in range(SEED0, SEED0 + SEEDS):
        pct, row, lacked, tidy = _follow(seed, sensor, term, t0)
        got.append(pct)
        rows.append(f"  seed {seed:2d}: {row}")
        missing += lacked
        clean += tidy
        clean_near += tidy and abs(pct / 10.0 - 1) <= 0.1 + 1e-9
    g = np.array(got)
    near = int(np.sum(np.abs(g / 10.0 - 1) <= 0.1 + 1e-9))
    chance = float(sps.binom.cdf(near, g.size, 0.8))  # P(so few or fewer | a share of 80 %)
    print(
        f"\n{term} from {t0:.0f} s:\n" + "\n".join(rows) + f"\n{term}: within +-10 % of the target on {near}/{g.size} "
        f"seeds ({missing} without the term after T0; {clean_near} of the {clean} whose every fit had the "
        "generator's model)"
    )
    assert missing <= SEEDS // 5
    assert 9.0 <= np.median(g) <= 11.0
    assert chance >= 0.05, f"{near}/{g.size} within +-10 %: below 80 % beyond chance"


def test_a_time_from_over_1_35_times_the_target_is_rough_and_staged() -> None:
    """+-33 % now after 50 min: the time for +-25 % (1.32 times) is given plainly, the one
    for +-10 % (3.3 times) marked rough with its check, the line saying why."""
    term = {"interval_pct": 33.0, "expected_pct": 32.0, "record_s_for_10pct": 30000.0, "record_s_for_25pct": 5000.0}
    term["recheck_s_for_10pct"] = 3000.0 + 5400.0
    doc = {"source": {"duration_s": 3000.0}, "channels": {"gx": {"terms": {"K": term}}}}
    text = advice.analysis_text(doc)
    assert "+-25 % after about 33 min more, +-10 % after about 7.5 h more (rough: ask again in 1.5 h)" in text
    assert "(rough): the term is over 1.35 times that target now" in text
    term["recheck_s_for_10pct"] = None  # no check to give: the mark alone
    assert "+-10 % after about 7.5 h more (rough);" not in advice.analysis_text(doc)
    assert "+-10 % after about 7.5 h more (rough)\n" in advice.analysis_text(doc)
    term["interval_pct"] = 13.0
    assert "(rough)" not in advice.analysis_text(doc)


@pytest.mark.parametrize(
    "pct, check, final, want",
    [
        (13.0, 5000.0, 9000.0, None),  # under 1.35 times the target: firm, no check
        (20.0, 5000.0, 9000.0, 5000.0),  # rough, the check before the time
        (20.0, 9500.0, 9000.0, math.sqrt(3000.0 * 9000.0)),  # the check past the time: half-way in log
        (20.0, None, 9000.0, math.sqrt(3000.0 * 9000.0)),  # no check from the prediction: half-way
        (20.0, 5000.0, None, None),  # no time to follow (model error): no check either
    ],
)
def test_a_check_is_kept_only_for_a_rough_time_and_before_it(pct, check, final, want) -> None:
    term = {"interval_pct": pct, "record_s_for_10pct": final, "recheck_s_for_10pct": check}
    term |= {"record_s_for_25pct": None, "recheck_s_for_25pct": None}
    advice._stage(term, 3000.0)
    assert term["recheck_s_for_10pct"] == (pytest.approx(want) if want else None)


def test_a_check_aims_at_1_25_times_the_target_or_a_third_of_the_term_now() -> None:
    assert advice.check_aim(33.0, 10) == pytest.approx(12.5)
    assert advice.check_aim(48.0, 10) == pytest.approx(16.0)
    assert advice.check_aim(None, 25) == pytest.approx(31.25)
