"""Dynamic Allan variance (dynamic.py) on the host: the warm-up found over
many seeds, from raw rows (sliding windows) and from the device's reports as
the host emulates them; false alarms within the stated level; a lost report
and a reset handled; the command's JSON, CSV and plot."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from imu_allan.analysis import dynamic
from imu_allan.channels import CHANNELS

FS = 100
SECONDS = 600
WARM = 0.15 * SECONDS
HOST = Path(__file__).resolve().parents[1]


def codes(seed: int, warm: bool) -> np.ndarray:
    """(6, n) codes, white noise of 3 counts; with ``warm``, ax's noise 3x higher
    at the start settling linearly by WARM, gx an exponential drift of time
    constant WARM / 2 that stops at WARM; ay az gy gz are controls."""
    rng = np.random.default_rng(seed)
    n = SECONDS * FS
    x = 512 + rng.normal(0, 3, (6, n))
    t = np.arange(n) / FS
    if warm:
        x[0] += rng.normal(0, 6, n) * np.clip(1 - t / WARM, 0, None)
        x[3] += 120 * (1 - np.exp(-np.minimum(t, WARM) / (WARM / 2)))
    return np.rint(x).astype(np.int64)


def both(c: np.ndarray) -> list[dynamic.Verdict]:
    """Reports every 30 s (their longest tau, 2.56 s, is where gx's cut shows:
    with 15 s reports, 1.28 s, the drift cut at 86 % of its course looks like
    one that goes on, and its end is read at the 95 % settling time, 1.5x late)."""
    reps = dynamic.device_reports_from_rows(c, FS, 30 * FS)
    return [
        dynamic.assess(dynamic.from_reports(reps)),
        dynamic.assess(dynamic.from_samples(c.astype(float), FS, list(CHANNELS))),
    ]


SEEDS = range(10)


@pytest.fixture(scope="module")
def verdicts() -> dict:
    return {(s, w): both(codes(100 + s, w)) for s in SEEDS for w in (True, False)}


def test_warm_up_found_within_30_percent_over_seeds(verdicts) -> None:
    """Every seed finds both warm-ups; within 30 % of the truth in at least
    95 % of the 40 cases (10 seeds, 2 channels, reports and raw windows) and
    never beyond 40 %: the end is the fitted transient's (analysis/transient.py),
    whose shape the first windows fix only roughly (measured: 39 of 40 within
    30 %, the other 36 % late: gx from reports, a steep power law fitted)."""
    errors = []
    for s in SEEDS:
        for v in verdicts[(s, True)]:
            for ch in ("ax", "gx"):
                got = v.warmup_s[ch]
                assert got is not None, (s, ch)
                errors.append(abs(got - WARM) / WARM)
    assert max(errors) <= 0.4 and np.mean(np.array(errors) <= 0.3) >= 0.95, errors


def test_false_alarms_at_most_the_stated_level(verdicts) -> None:
    """A control channel or a stationary run flagged (warm-up or departures):
    at most 1 - LEVEL = 5 % per channel.  Over 10 seeds x (4 + 6) channels x 2
    sources = 200 trials, 10 expected at the bound; 18 or more would have
    probability about 1 % if the rate were 5 %.  (Measured over 30 seeds of
    the stationary run: 8 of 180 from reports, 5 of 180 from raw windows.)"""
    alarms = trials = 0
    for (_s, warm), vs in verdicts.items():
        for v in vs:
            for ch in ("ay", "az", "gy", "gz") if warm else CHANNELS:
                trials += 1
                alarms += (v.warmup_s[ch] is not None) or not v.stationary[ch]
    assert trials == 200 and alarms < 18, alarms


def test_lost_report_makes_one_window_longer_and_exact() -> None:
    c = codes(7, False)
    reps = dynamic.device_reports_from_rows(c, FS, 15 * FS)
    full = dynamic.from_reports(reps)
    lost = dynamic.from_reports(reps[:3] + reps[4:])
    assert len(lost.t0) == len(full.t0) - 1
    assert lost.t0[3] == full.t0[3] and lost.t1[3] == full.t1[4]
    for k in range(6):
        assert lost.acc[3][0][k] == full.acc[3][0][k] + full.acc[4][0][k]
        assert lost.pairs[3, 0, k] == full.pairs[3, 0, k] + full.pairs[4, 0, k]


def test_reset_between_reports_starts_over() -> None:
    a = dynamic.device_reports_from_rows(codes(8, False)[:, :9000], FS, 3000)
    b = dynamic.device_reports_from_rows(codes(9, False)[:, :9000], FS, 3000)
    assert [len(r) for r in dynamic.runs(a + b)] == [3, 3]


def test_temperature_bins_when_the_temperature_moves() -> None:
    c = codes(10, False).astype(float)
    temp = np.linspace(300, 310, c.shape[1])
    ws = dynamic.from_samples(c, FS, list(CHANNELS), temp=temp)
    bins = dynamic.temperature_bins(ws)
    assert len(bins) >= 4 and sum(b["windows"] for b in bins) == len(ws.t0)
    still = dynamic.from_samples(c, FS, list(CHANNELS), temp=np.full(c.shape[1], 300.0))
    assert dynamic.temperature_bins(still) == []


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "imu_allan.cli", *args], capture_output=True, text=True, cwd=HOST)


def test_dynamic_command_json_csv_and_plot(tmp_path: Path) -> None:
    rows = tmp_path / "warm.tsv"
    c = codes(11, True)
    np.savetxt(rows, np.vstack((c, np.full(c.shape[1], 300))).T, fmt="%d", delimiter="\t")
    png = tmp_path / "dyn.png"
    proc = _cli("dynamic", str(rows), "--fs", "100", "--json", "--plot", str(png))
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert set(doc) >= {"windows", "warmup_s"}
    w = doc["windows"][0]
    assert set(w) >= {"t0_s", "t1_s", "temp", "adev", "taus_s", "departs"}
    assert len(w["adev"]["gx"]) == len(w["taus_s"]) and w["temp"] == 300.0
    assert abs(doc["warmup_s"]["gx"] - WARM) <= 0.3 * WARM and doc["warmup_s"]["ay"] is None
    assert png.stat().st_size > 10000
    csv = _cli("dynamic", str(rows), "--fs", "100", "--csv").stdout.splitlines()
    assert csv[0].startswith("t0_s,t1_s,temp,channel,tau_s,adev")
    assert len(csv) - 1 == len(doc["windows"]) * 6 * len(w["taus_s"])
    text = _cli("dynamic", str(rows), "--fs", "100").stdout
    assert "gx: warm-up" in text and "ay: no warm-up; stationary" in text
    bad = _cli("dynamic", str(rows), "--fs", "100", "--level", "2")
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
