"""Recording-length advice (advice.py): the interval arithmetic, the device's
rule (exact pair counts), the advised time checked by recording it, and the
analyze JSON and text that carry it."""

from __future__ import annotations

import gzip
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_real_recording import NAME, _find

from imu_allan.analysis import advice, dynamic
from imu_allan.analysis.pipeline import Options, analyze
from imu_allan.profiles import build_profile
from imu_allan.sources.detect import SampleSource, Source
from imu_allan.stats.edf import chi2_interval

HOST = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("nu", [3.0, 20.0, 400.0, 1e5])
def test_halfwidth_is_the_chi2_interval_and_edf_for_inverts_it(nu: float) -> None:
    lo, hi = chi2_interval(1.0, nu, 0.95)
    assert advice.halfwidth(nu) == pytest.approx((math.sqrt(hi) - math.sqrt(lo)) / 2, rel=1e-12)
    assert advice.edf_for(advice.halfwidth(nu)) == pytest.approx(nu, rel=1e-6)
    if nu >= 400:  # a deviation's relative standard error is 1/sqrt(2 nu)
        assert advice.halfwidth(nu) == pytest.approx(1.96 / math.sqrt(2 * nu), rel=0.01)


def test_device_advice_time_is_when_the_level_holds_the_pairs() -> None:
    """At the advised time the term's level has floor(n/m) - 1 >= 50 pairs
    (100/sqrt(2*50) = 10 %); one cluster earlier it has not."""
    rng = np.random.default_rng(5)
    codes = np.rint(512 + rng.normal(0, 3, (6, 30000))).astype(np.int64)
    rep = dynamic.device_reports_from_rows(codes, 100, 30000)[-1]
    adv = advice.device_advice(rep)
    for _ch, terms in adv.items():
        for _name, a in terms.items():
            m = 1 << a["level"]
            assert a["pct"] == pytest.approx(100 / math.sqrt(2 * (30000 // m - 1)))
            for target, pairs in ((10, 50), (25, 8)):
                n = round(a[f"record_s_for_{target}pct"] * 100)
                assert n // m - 1 >= pairs and (n - m) // m - 1 < pairs
                assert 100 / math.sqrt(2 * (n // m - 1)) <= target
    line = advice.monitor_line(rep)
    assert line.startswith("record: B +-") and len(line) <= 80


def test_analyze_reports_warm_up_and_record_times(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    n, fs, warm = 60000, 100, 90.0
    t = np.arange(n) / fs
    x = 512 + rng.normal(0, 3, (7, n))
    x[3] += 120 * (1 - np.exp(-np.minimum(t, warm) / (warm / 2)))
    rows = tmp_path / "cold.tsv"
    np.savetxt(rows, np.rint(x.T).astype(int), fmt="%d", delimiter="\t")

    def run(*a):
        return subprocess.run(
            [
                sys.executable,
                "-m",
                "imu_allan.cli",
                "analyze",
                str(rows),
                "--fs",
                "100",  # noqa: E731
                "--no-model",
                "--channels",
                "gx,gy",
                *a,
            ],
            capture_output=True,
            text=True,
            cwd=HOST,
        )

    proc = run("--json")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    w = doc["warmup"]
    assert abs(w["warmup_s"]["gx"] - warm) <= 0.3 * warm and w["warmup_s"]["gy"] is None
    assert w["without_warmup"]["skip_s"] == w["warmup_s"]["gx"]
    assert w["without_warmup"]["left_out_s"] == w["without_warmup"]["skip_s"]  # raw rows: cut where asked
    n_term = doc["channels"]["gy"]["terms"]["N"]
    assert n_term["record_s_for_10pct"] > 0 and n_term["record_s_for_25pct"] < n_term["record_s_for_10pct"]
    skipped = json.loads(run("--json", "--skip", "300").stdout)
    assert skipped["source"]["n"] == n - 300 * fs
    text = run().stdout
    assert "Warm-up and stationarity" in text and "gx: warm-up" in text and "Recording length" in text


def test_a_target_the_interval_meets_now_is_advised_within_the_record() -> None:
    """The first 1000 s of the real recording (test_real_recording.py): its accelerometers keep
    a mount mode whose frequency or quality the fit may hold at its search's bound.  Whatever a
    term sits beside, a target its interval meets now is advised a time within the record."""
    src = _find()
    if src is None:
        pytest.skip(f"the real recording {NAME} is absent (see test_real_recording.py)")
    with gzip.open(src, "rt") as f:
        x = np.loadtxt(f, max_rows=100_000)[:, :3].T  # ax ay az, 100 Hz
    chans = ["ax", "ay", "az"]
    ss = SampleSource("csv", "first 1000 s", chans, lambda: iter([x]), False, fs=100.0)
    profile = build_profile(None, {c: (1.0, "m/s^2") for c in chans})
    res = analyze(Source("first 1000 s", ss, None), profile, Options(fs=100.0, model=False, extra_curves=False))
    advice.add_to_analysis(res.doc, fits=res.fits)
    duration = res.doc["source"]["duration_s"]
    assert duration == pytest.approx(x.shape[1] / 100.0)
    met = []
    for ch in res.doc["channels"].values():
        for name, term in ch["terms"].items():
            for target in advice.TARGETS_PCT:
                predicted = term and term.get("expected_pct") is not None  # not LP: its interval is fc's
                if predicted and term["interval_pct"] is not None and term["interval_pct"] <= target:
                    met.append((name, target, term["interval_pct"], term[f"record_s_for_{target}pct"]))
    assert len(met) >= 6  # N at least, on each channel and for both targets
    late = [m for m in met if m[3] is None or m[3] > duration * (1 + 1e-9)]
    assert not late, late
