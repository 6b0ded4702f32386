"""`imu-allan analyze` puts the answer first: one table, a row per channel, N, B
and K with their 95 % intervals in the units datasheets quote, the same values
as --json; --brief prints that table alone; the whole text fits 80 columns; a
negative FIT% is explained where it appears; the device's N, read at one tau,
is set beside the fitted N with the reason they differ."""

from __future__ import annotations

import contextlib
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import CH, exact_acc, line, report_lines, thesis_like, write_rows

G0 = 9.80665
# from a rate unit to the datasheet's unit, worked out here: sqrt(s) -> sqrt(h) is
# sqrt(3600) = 60, 1/s -> 1/h is 3600, g -> ug is 1e6 / g0
TO_DATASHEET = {
    "gyro": {"N": 60.0, "B": 3600.0, "K": 3600.0 * 60.0},
    "acc": {"N": 60.0, "B": 1e6 / G0, "K": 3600.0 * 60.0},
}
NUMBER = r"-?\d[\d.e+-]*"
CELL = re.compile(rf"^(?:({NUMBER}) \[({NUMBER}), ({NUMBER})\]|< ({NUMBER})|-)$")
LEVELS, FS = 15, 100


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """The same recording analyzed three ways (text, --json, --brief)."""
    from imu_allan.cli.main import main

    d = tmp_path_factory.mktemp("answer")
    rows = write_rows(d / "rows.txt", thesis_like(30000, 11))
    out = {}
    for name, extra in (("text", []), ("json", ["--json"]), ("brief", ["--brief"])):
        path = d / f"{name}.out"
        with open(path, "w") as f, contextlib.redirect_stdout(f):
            assert main(["analyze", str(rows), "--fs", "100", "--no-warmup", *extra]) == 0
        out[name] = path.read_text()
    return out


def _table(text: str) -> list[str]:
    """The answer table: from its title to the blank line before its notes."""
    lines = text.splitlines()
    start = next(i for i, s in enumerate(lines) if s.startswith("Noise terms (IEEE 952)"))
    end = next(i for i in range(start + 1, len(lines)) if lines[i].startswith(("! ", "'< x'")))
    return lines[start:end]


def _rows(table: list[str]) -> dict[str, list[str]]:
    out = {}
    for s in table:
        cells = re.split(r"\s{2,}", s.strip())
        if cells[0] in CH:
            out[cells[0]] = cells[1:]
    return out


def test_the_table_comes_first_and_holds_the_json_values(run: dict[str, str]) -> None:
    before = run["text"][: run["text"].index("Noise terms (IEEE 952)")]
    assert before.rstrip("\n").count("\n\n") == 0 and before.endswith("\n\n")  # only the source before it
    assert "rows.txt: rows file, 30000 samples at 100 Hz" in " ".join(before.split())
    assert run["text"].index("Noise terms (IEEE 952)") < run["text"].index("Details")
    doc = json.loads(run["json"])
    rows = _rows(_table(run["text"]))
    assert sorted(rows) == sorted(CH)
    checked = 0
    for ch, cells in rows.items():
        c = doc["channels"][ch]
        for term, cell in zip(("N", "B", "K"), cells):
            m = CELL.match(cell)
            assert m, f"{ch} {term}: {cell!r}"
            f = TO_DATASHEET[c["kind"]][term]
            t = c["terms"][term]
            if m.group(1):
                for got, key in zip(m.group(1, 2, 3), ("value", "low", "high")):
                    assert float(got) == float(f"{t[key] * f:.3g}"), (ch, term, key)
                checked += 1
            elif m.group(4):
                assert t is None and float(m.group(4)) == float(f"{c['upper_bounds'][term] * f:.3g}")
            else:
                assert t is None
    assert checked >= 6  # N at least, on every channel


def test_the_table_names_the_datasheet_units(run: dict[str, str]) -> None:
    table = "\n".join(_table(run["text"]))
    for unit in ("deg/sqrt(h)", "deg/h", "m/s/sqrt(h)", "ug"):
        assert re.search(rf"(^|\s){re.escape(unit)}(\s|$)", table, re.M), unit


def test_brief_prints_the_table_alone(run: dict[str, str]) -> None:
    brief = run["brief"]
    assert brief.startswith("Noise terms (IEEE 952)")
    assert "\nDetails\n" not in brief and "Allan deviation (overlapping)" not in brief
    assert "\nDetails\n" in run["text"]
    assert _table(brief) == _table(run["text"])
    assert len(brief.splitlines()) <= 24  # one screen


def test_every_line_fits_80_columns(run: dict[str, str]) -> None:
    assert max(len(s) for s in run["brief"].splitlines()) <= 80
    # the analysis' own text: up to the sections other commands share (warm-up, recording length)
    own = run["text"].split("\nRecording length")[0].split("\nWarm-up")[0]
    too_long = [s for s in own.splitlines() if len(s) > 80]
    assert too_long == []


def test_a_negative_fit_percent_is_explained_where_it_first_appears(run: dict[str, str]) -> None:
    doc = json.loads(run["json"])
    first = next(ch for ch, c in doc["channels"].items() if c.get("model"))
    fp = doc["channels"][first]["model"]["fit_percent"]
    assert fp["signal"] < 0  # two independent noises: about -41 %
    text = run["text"]
    block = text[text.index(f"\n{first} [") :]
    block = block[: block.index("\n\n", 1)]
    assert f"time series {fp['signal']:.1f} %" in block
    assert "below 0 % worse" in block and "two independent noises" in block
    assert text.count("two independent noises") == 1  # said once, not per channel


# ---- the device's N, read at one tau, beside the fitted N ----------------------------------


def _device_terms(rows: np.ndarray, ch: str, digits: bool = True) -> tuple[int, float, int, float]:
    """The device's N and B, independently from exact sums (docs/protocol.md): N =
    adev * sqrt(tau) at the octave nearest 1 s, B = min(adev) / 0.664 over the levels
    with at least 8 pairs; 3 significant digits as printed in T lines (``digits``)."""
    codes = [int(v) for v in rows[:, CH.index(ch)]]
    adev = {}
    for k in range(LEVELS):
        m, pairs = 1 << k, len(rows) // (1 << k) - 1
        if pairs > 0:
            adev[k] = (pairs, math.sqrt(exact_acc(codes, m, pairs) / (2 * m * m * pairs)))
    kn = min(adev, key=lambda k: (abs(2**k / FS - 1), k))
    kb = min((k for k in adev if adev[k][0] >= 8), key=lambda k: (adev[k][1], k))
    n, b = adev[kn][1] * math.sqrt(2**kn / FS), adev[kb][1] / 0.664
    return (kn, float(f"{n:.3g}"), kb, float(f"{b:.3g}")) if digits else (kn, n, kb, b)


def test_the_device_n_read_at_one_tau_is_set_beside_the_fit(tmp_path: Path, run_cli) -> None:
    rows = thesis_like(30000, 12)  # white noise plus a random walk: at 1.28 s the walk adds a lot
    data = write_rows(tmp_path / "rows.txt", rows)
    lines = report_lines(rows, LEVELS)
    t_lines = []
    for ch in CH:
        kn, n, kb, b = _device_terms(rows, ch)
        t_lines.append(line(f"T,0,{ch},{kn},{n:g},{kb},{b:g}"))
    log = tmp_path / "dev.log"
    log.write_bytes(b"".join(lines[:-1] + t_lines + lines[-1:]))
    rc, out, err = run_cli("analyze", data, "--fs", "100", "--device", log, "--no-warmup", "--no-model", "--json")
    assert rc == 0, err
    doc = json.loads(out)
    rc, text, err = run_cli("analyze", data, "--fs", "100", "--device", log, "--no-warmup", "--no-model", "--brief")
    assert rc == 0, err
    for ch in CH:
        c = doc["channels"][ch]
        k, n, _, _ = _device_terms(rows, ch, digits=False)  # full precision, from the report's row
        d = c["device_terms"]["N"]
        assert d["tau_s"] == 2**k / FS and math.isclose(d["value"], n * c["scale_per_count"], rel_tol=1e-12)
        assert d["differs"] and d["value"] > 1.5 * c["terms"]["N"]["value"]
        # the reason holds: the fitted terms, all of them, predict what the device read at its tau
        assert abs(d["model_at_tau"] / d["value"] - 1) < 0.1, ch
        assert d["other_share_pct"] > 40
        f = TO_DATASHEET[c["kind"]]["N"]
        shown = float(f"{d['value'] * f:.3g}")
        assert f"{ch} {shown:g}" in " ".join(text.split()), ch
    said = " ".join(text.split())
    assert "reads N as adev*sqrt(tau) at one tau (1.28 s)" in said
    assert "The fit separates N from the other terms over the whole curve" in said


def test_a_row_that_could_mislead_says_so_under_it(tmp_path: Path, run_cli) -> None:
    """A stuck gyro's empty row and a channel whose spikes were taken out carry a word."""
    rng = np.random.default_rng(2)
    codes = np.clip(np.rint(rng.normal(500, 2, (20000, 7))), 0, 1023).astype(int)
    codes[:, 3] = 512  # gx stuck
    codes[5000:5003, 0] = 1000  # a knock on ax
    rows = write_rows(tmp_path / "rows.txt", codes)
    rc, out, err = run_cli("analyze", rows, "--fs", "100", "--no-model", "--no-warmup", "--json")
    assert rc == 0, err
    doc = json.loads(out)
    spikes = doc["channels"]["ax"]["outliers"]["count"]
    assert spikes >= 3
    rc, brief, err = run_cli("analyze", rows, "--fs", "100", "--no-model", "--no-warmup", "--brief")
    assert rc == 0, err
    lines = brief.splitlines()
    under = {ln.split()[0]: lines[i + 1] for i, ln in enumerate(lines[:-1]) if ln.split()[:1] in ([c] for c in CH)}
    assert under["gx"].strip().startswith("! constant") and _rows(lines)["gx"] == ["-", "-", "-"]
    assert under["ax"].strip() == f"! {spikes} samples of spikes or bursts replaced (see the details)"
    assert not under["ay"].strip().startswith("!")
