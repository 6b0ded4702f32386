"""The dynamic Allan variance from the real firmware's periodic reports (in
simavr): a warm-up transient is found where it is, a stationary run shows
none, and every window equals, exactly, the non-overlapping Allan variance of
the raw rows it covers."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import cli

from imu_allan.analysis.dynamic import from_reports, runs
from imu_allan.device.records import decode_bytes
from imu_allan.render.screen import Monitor
from imu_allan.stats.reference import octave_avar

FS = 100
SECONDS = 1200  # 20 min of device time per run (simavr: about 12 s of CPU)
WARM = 0.15 * SECONDS  # the transient is over after the first 15 %
INTERVAL = 30  # a report every 30 s: 40 windows


def warm_rows(seed: int, warm: bool) -> np.ndarray:
    """7 columns of codes: white noise of 3 counts everywhere; with ``warm``,
    ax's noise starts 3x higher and settles linearly to its level at WARM, gx
    drifts as 120 (1 - exp(-t / (WARM / 2))) counts until WARM (86 % of the
    step), then stays; the others are controls."""
    rng = np.random.default_rng(seed)
    n = SECONDS * FS
    x = 512 + rng.normal(0, 3, (7, n))
    t = np.arange(n) / FS
    x[6] = 300
    if warm:
        x[0] += rng.normal(0, 6, n) * np.clip(1 - t / WARM, 0, None)
        x[3] += 120 * (1 - np.exp(-np.minimum(t, WARM) / (WARM / 2)))
    return np.rint(x.T).astype(np.int64)


@pytest.fixture(scope="module")
def device_runs(tmp_path_factory) -> dict:
    tmp = tmp_path_factory.mktemp("dynamic")
    uart = tmp / "uart.txt"
    uart.write_text(f"0\tinterval {INTERVAL}\\r\n")
    out = {}
    for name, seed, warm in (("warm", 3, True), ("steady", 4, False)):
        rows, log = tmp / f"{name}.tsv", tmp / f"{name}.log"
        codes = warm_rows(seed, warm)
        np.savetxt(rows, codes, fmt="%d", delimiter="\t")
        cli("sim", "--adc", str(rows), "-o", str(log), "--fs", str(FS), "--uart-in", str(uart))
        out[name] = (codes, log)
    return out


def test_warm_up_found_within_30_percent_on_the_simulated_device(device_runs) -> None:
    _, log = device_runs["warm"]
    doc = json.loads(cli("dynamic", str(log), "--json").stdout)
    assert doc["source"]["kind"] == "device reports" and len(doc["windows"]) >= SECONDS // INTERVAL - 1
    warm = doc["warmup_s"]
    for ch in ("ax", "gx"):
        assert warm[ch] is not None and abs(warm[ch] - WARM) <= 0.3 * WARM, (ch, warm)
    for ch in ("ay", "az", "gy", "gz"):
        assert warm[ch] is None and doc["stationary"][ch]["stationary"], (ch, doc["stationary"][ch])
    w0 = doc["windows"][0]
    assert set(w0) >= {"t0_s", "t1_s", "temp", "adev", "taus_s", "departs"}
    assert w0["departs"]["ax"] and w0["departs"]["gx"] and w0["temp"] == 300.0


def test_stationary_device_run_shows_no_warm_up(device_runs) -> None:
    _, log = device_runs["steady"]
    doc = json.loads(cli("dynamic", str(log), "--json").stdout)
    assert all(v is None for v in doc["warmup_s"].values()), doc["warmup_s"]


def test_device_windows_equal_the_raw_rows_exactly(device_runs) -> None:
    """A window of reports A -> B at level k holds pairs pA+1 .. pB: the
    clusters pA .. pB, rows pA*m .. (pB+1)*m.  Its integer sum must equal the
    exact sum of squared cluster-sum differences of those rows, and its
    variance the float64 reference over them (as `check` does for a report)."""
    codes, log = device_runs["warm"]
    reports = runs(decode_bytes(log.read_bytes()).reports)[-1]
    ws = from_reports(reports)
    assert len(reports) >= SECONDS // INTERVAL - 1
    compared = 0
    before = np.zeros((6, ws.ms.size), dtype=np.int64)
    for w in range(len(reports)):
        after = before + ws.pairs[w]
        for c in range(6):
            for k in (0, 3, 6, 9, 11):
                m, pa, pb = int(ws.ms[k]), int(before[c, k]), int(after[c, k])
                if pb <= pa:
                    continue
                seg = codes[pa * m : (pb + 1) * m, c]
                sums = seg.reshape(-1, m).sum(axis=1)
                exact = sum(int(d) * int(d) for d in np.diff(sums))
                assert ws.acc[w][c][k] == exact, (w, c, k)
                ref = octave_avar(seg, k + 1)[k]
                assert ref.pairs == pb - pa
                assert abs(ws.var[w, c, k] - ref.avar) <= 1e-12 * ref.avar
                compared += 1
        before = after
    assert compared > 500


def test_monitor_shows_the_advice_line_at_every_report(device_runs) -> None:
    """Fed the device's log report by report, the monitor's 80x24 screen holds
    the recording advice, recomputed from each new report."""
    _, log = device_runs["steady"]
    data = log.read_bytes()
    mon = Monitor("/dev/ttyUSB0", 115200, "x.log")
    seen = []
    for a in range(0, len(data), 2048):
        mon.feed(data[a : a + 2048])
        if mon.report is None or (seen and seen[-1][0] == mon.report.seq):
            continue
        lines, _, _ = mon.screen(80, 24)
        assert len(lines) <= 24 and all(len(x) <= 80 for x in lines)
        advice = [x for x in lines if x.startswith("record: ")]
        assert advice, lines
        seen.append((mon.report.seq, advice[0]))
    assert len({s for s, _ in seen}) >= SECONDS // INTERVAL - 1
    assert len({a for _, a in seen}) > 3  # it moves with the reports


def test_analyze_of_the_device_log_reports_the_warm_up_and_cuts_it_at_a_report(device_runs) -> None:
    """`analyze LOG` (the device's results alone) finds the same warm-up, gives
    the terms from the device's sums after it, and `--skip` cuts the sums at
    the first report after the time asked (its last report minus that one)."""
    _, log = device_runs["warm"]
    doc = json.loads(cli("analyze", str(log), "--json", "--no-model").stdout)
    w = doc["warmup"]
    assert w["from"] == "device reports" and abs(w["warmup_s"]["gx"] - WARM) <= 0.3 * WARM
    assert w["without_warmup"]["skip_s"] == max(v for v in w["warmup_s"].values() if v is not None)
    # the device's sums are cut at the first report at or after the warm-up's end
    first = next(
        r
        for r in runs(decode_bytes(log.read_bytes()).reports)[-1]
        if r.header.n >= round(w["without_warmup"]["skip_s"] * FS)
    )
    left_out = first.header.n / FS
    assert w["without_warmup"]["left_out_s"] == pytest.approx(left_out, abs=1.0 / FS)
    assert doc["channels"]["gy"]["terms"]["N"]["record_s_for_10pct"] is not None
    reports = runs(decode_bytes(log.read_bytes()).reports)[-1]
    cut = next(r for r in reports if r.header.n >= 200 * FS)
    skipped = json.loads(cli("analyze", str(log), "--json", "--no-model", "--no-warmup", "--skip", "200").stdout)
    assert skipped["source"]["n"] == reports[-1].header.n - cut.header.n
    assert any("--skip 200" in n for n in skipped["notes"])
