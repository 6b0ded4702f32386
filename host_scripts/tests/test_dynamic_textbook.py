"""The warm-up's end on raw recordings from a generator written here from the
textbook formulas (IEEE 952: white noise of sample sd N sqrt(fs), rate random
walk as the running sum of steps of sd K sqrt(dt)), not the project's noise
catalogue: an exponential drift 95 % settled at 15 % of the record (three
time constants, then constant), strong and weak, and a noise level settling
linearly to its final value at 15 %.  The weak drift departs in one or two
windows only; its end comes from the fitted decay (analysis/transient.py).  A
drift of half a sample sd is found by the first window's own test alone."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_allan.analysis import dynamic

FS = 100.0
SECONDS = 7200.0
WARM = 0.15 * SECONDS
N = 0.05  # white noise, units sqrt(s)
K = N * 1e-3  # rate random walk, units / sqrt(s)
SD = N * math.sqrt(FS)  # one sample's sd
SEEDS = range(8)
CHANNELS = ["strong", "weak", "settling", "control"]


def textbook(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.standard_normal(n) * SD + np.cumsum(rng.standard_normal(n)) * K / math.sqrt(FS)


def drift(t: np.ndarray, amplitude: float) -> np.ndarray:
    """amplitude (exp(-t / tau) - exp(-3)) / (1 - exp(-3)), tau = WARM / 3: the
    exponential's 95 % settling time is WARM, where it stops (continuously)."""
    tau = WARM / 3
    y = amplitude * (np.exp(-t / tau) - math.exp(-3.0)) / (1 - math.exp(-3.0))
    return np.where(t < WARM, y, 0.0)


def recording(seed: int, warm: bool) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n = int(SECONDS * FS)
    t = np.arange(n) / FS
    x = np.stack([textbook(rng, n) for _ in CHANNELS])
    if warm:
        x[0] += drift(t, 5 * SD)
        x[1] += drift(t, 1 * SD)  # at its start still 25x the white ADEV at 41 s
        x[2] += rng.standard_normal(n) * SD * np.clip(1 - t / WARM, 0, None)
    return x


@pytest.fixture(scope="module")
def verdicts() -> dict:
    return {
        (s, w): dynamic.assess(dynamic.from_samples(recording(200 + s, w), FS, CHANNELS))
        for s in SEEDS
        for w in (True, False)
    }


def test_strong_and_weak_drifts_and_a_settling_noise_end_within_30_percent(verdicts) -> None:
    """Measured on seeds 0-39 of this generator: strong drift 40 of 40 within
    30 % (-17..+3 %), weak 37 of 40 (-24..+78 %), settling noise 39 of 40
    (-32..+17 %); on seeds 40-79: 40, 36 (three cut at the stretch's end by a
    later window departing) and 38 of 40.  The departing stretch alone ended
    the weak one at 225-450 s.
    Here: the strong one always, the others on all but at most 2 of 8."""
    errors: dict[str, list[float]] = {ch: [] for ch in CHANNELS[:3]}
    for s in SEEDS:
        v = verdicts[(s, True)]
        for ch in errors:
            got = v.warmup_s[ch]
            assert got is not None, (s, ch)
            errors[ch].append(got / WARM - 1)
            stretch = v.transient[ch].stretch_s
            assert stretch <= got + 1e-9, (s, ch, stretch, got)  # the fit extends, never cuts, the stretch
    for ch, e in errors.items():
        within = sum(abs(x) <= 0.3 for x in e)
        assert within >= (len(e) if ch == "strong" else len(e) - 2), (ch, e)
    weak_stretch = [verdicts[(s, True)].transient["weak"].stretch_s / WARM - 1 for s in SEEDS]
    assert min(weak_stretch) < -0.3  # what the departing windows alone would have said


def test_a_half_sd_drift_is_found_by_the_first_windows_own_test() -> None:
    """A drift of half a sample sd (its own generator stream) departs at the
    first window's longest tau only, p about 1e-3 to 1e-4: below the first
    window's one-sided level over its 13 taus (half the 5 % budget: 0.025 / 13
    = 1.9e-3), above the level of every window and tau (0.025 / 403 = 6e-5).
    Measured on seeds 0-39: found on 37 of 40 (the test of every window alone,
    at the whole budget: 9 of 40).  Here: on at least 6 of 8."""
    found = 0
    for s in SEEDS:
        rng = np.random.default_rng(10_000 + 200 + s)
        n = int(SECONDS * FS)
        x = textbook(rng, n) + drift(np.arange(n) / FS, 0.5 * SD)
        v = dynamic.assess(dynamic.from_samples(x[None, :], FS, ["half"]))
        k = v.hit[0, 0].nonzero()[0]
        if v.warmup_s["half"] is not None:
            found += 1
            assert k.size and k.max() >= v.hit.shape[2] - 2, (s, k)  # the drift shows at the longest taus
            assert v.threshold[0] < 1e-4 < v.lead_threshold[0] < 2e-3, (v.threshold, v.lead_threshold)
    assert found >= 6, found


def test_no_warm_up_on_the_control_channel_nor_on_a_stationary_run(verdicts) -> None:
    """At most 1 - LEVEL = 5 % per channel: 8 seeds x (1 control + 4 stationary)
    = 40 trials, 2 expected at the bound; 5 or more would have probability
    about 5 % at that rate.  (Measured over 200 stationary runs of this
    generator: 28 of 800 channels, 3.5 %, 15 of them by the first window's own
    test; before that test: 19 of 800, 2.4 %.)"""
    alarms = 0
    for (_s, warm), v in verdicts.items():
        for ch in ["control"] if warm else CHANNELS:
            alarms += (v.warmup_s[ch] is not None) or not v.stationary[ch]
    assert alarms < 5, alarms
