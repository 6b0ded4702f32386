"""The noise terms the device reads off its own deviations (T records,
docs/protocol.md): decoded into ``decode --json``'s ``terms`` and recomputed
by ``imu-allan check`` from the report's integers."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from conftest import CH, exact_acc, line, report_lines, thesis_like, write_rows

FS = 100
LEVELS = 12


def _sig3(v: float) -> str:
    return f"{float(f'{v:.3g}'):g}" if v else "0"


def _terms(rows: np.ndarray, ch: str, fs: int = FS, levels: int = LEVELS) -> tuple[int, float, int, float]:
    """N and B of one channel, independently: float adev from exact sums."""
    n = len(rows)
    codes = [int(v) for v in rows[:, CH.index(ch)]]
    adev = {}
    for k in range(levels):
        m, pairs = 1 << k, max(n // (1 << k) - 1, 0)
        if pairs:
            adev[k] = (pairs, math.sqrt(exact_acc(codes, m, pairs) / (2 * m * m * pairs)))
    kn = min(adev, key=lambda k: (abs(2**k / fs - 1), k))
    kb = min((k for k in adev if adev[k][0] >= 8), key=lambda k: (adev[k][1], k))
    return kn, adev[kn][1] * math.sqrt(2**kn / fs), kb, adev[kb][1] / 0.664


def _log(tmp_path: Path, rows: np.ndarray, t_lines: list[bytes]) -> Path:
    lines = report_lines(rows, LEVELS)
    log = tmp_path / "dev.log"
    log.write_bytes(b"".join(lines[:-1] + t_lines + lines[-1:]))
    return log


def _t_lines(rows: np.ndarray, fudge=None) -> list[bytes]:
    out = []
    for ch in CH:
        kn, n, kb, b = _terms(rows, ch)
        if fudge:
            kn, n, kb, b = fudge(ch, kn, n, kb, b)
        out.append(line(f"T,0,{ch},{kn},{_sig3(n)},{kb},{_sig3(b)}"))
    return out


def test_decode_json_holds_the_device_terms(tmp_path: Path, run_cli) -> None:
    rows = thesis_like(3000, 5)
    rc, out, err = run_cli("decode", "--json", _log(tmp_path, rows, _t_lines(rows)))
    assert rc == 0, err
    terms = json.loads(out)["terms"]
    assert sorted(terms) == sorted(CH)
    for ch in CH:
        kn, n, kb, b = _terms(rows, ch)
        pn, pb = len(rows) // 2**kn - 1, len(rows) // 2**kb - 1
        assert terms[ch]["N"] == {
            "value": float(_sig3(n)),
            "tau_s": 2**kn / FS,
            "pairs": pn,
            "pct": round(100 / math.sqrt(2 * pn), 3),
        }
        assert terms[ch]["B"] == {
            "value": float(_sig3(b)),
            "tau_s": 2**kb / FS,
            "pairs": pb,
            "pct": round(100 / math.sqrt(2 * pb), 3),
        }


def test_check_recomputes_the_terms(tmp_path: Path, run_cli) -> None:
    rows = thesis_like(3000, 6)
    data = write_rows(tmp_path / "rows.txt", rows)
    rc, out, err = run_cli("check", _log(tmp_path, rows, _t_lines(rows)), data)
    assert rc == 0, out + err
    assert "noise terms (T): 12 recomputed" in out


def test_check_fails_a_term_beyond_the_printed_precision(tmp_path: Path, run_cli) -> None:
    rows = thesis_like(3000, 7)
    data = write_rows(tmp_path / "rows.txt", rows)

    def off(ch, kn, n, kb, b):  # B of gy 1.5 units of its third digit high
        return (kn, n, kb, b + 1.5 * 10 ** (math.floor(math.log10(b)) - 2)) if ch == "gy" else (kn, n, kb, b)

    rc, out, _ = run_cli("check", _log(tmp_path, rows, _t_lines(rows, off)), data)
    assert rc != 0 and "gy B: device" in out and "beyond the printed precision" in out

    def level(ch, kn, n, kb, b):  # N read at the wrong octave
        return (kn + 1, n, kb, b) if ch == "ax" else (kn, n, kb, b)

    rc, out, _ = run_cli("check", _log(tmp_path, rows, _t_lines(rows, level)), data)
    assert rc != 0 and "ax N: device used level" in out


def test_a_term_needs_its_pairs_and_a_dash_only_without_them(tmp_path: Path, run_cli) -> None:
    rows = thesis_like(12, 8)  # 12 samples: level 0 has 11 pairs, level 1 only 5
    lines = report_lines(rows, LEVELS)
    t = [
        line(f"T,0,{ch},{_terms(rows, ch)[0]},{_sig3(_terms(rows, ch)[1])},0,{_sig3(_terms(rows, ch)[3])}") for ch in CH
    ]
    log = tmp_path / "dev.log"
    log.write_bytes(b"".join(lines[:-1] + t + lines[-1:]))
    rc, out, _ = run_cli("decode", "--json", log)
    assert rc == 0
    assert json.loads(out)["terms"]["ax"]["B"]["tau_s"] == 1 / FS
    # B at level 1 (5 pairs, fewer than 8), and a dash where level 0 has 11 pairs:
    # both contradict the rows, so both lines are refused, counted and said
    t = [line(f"T,0,{ch},{_terms(rows, ch)[0]},{_sig3(_terms(rows, ch)[1])},1,1") for ch in CH[:3]]
    t += [line(f"T,0,{ch},{_terms(rows, ch)[0]},{_sig3(_terms(rows, ch)[1])},-,-") for ch in CH[3:]]
    log.write_bytes(b"".join(lines[:-1] + t + lines[-1:]))
    rc, out, err = run_cli("decode", "--json", log)
    doc = json.loads(out)
    assert rc == 0 and "terms" not in doc and doc["errors"]["inconsistent_lines"] == 6
    assert "refused the T line of ax (ax B: level 1, whose row has 5 pairs (the term needs 8))" in err
    assert "refused the T line of gz (gz B: device -, but level 0 has 8 pairs or more)" in err
