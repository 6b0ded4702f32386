"""`imu-allan check` against logs encoded in the test from exact Python ints."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import exact_acc, report_lines, thesis_like, write_rows


@pytest.fixture(scope="module")
def rows() -> np.ndarray:
    return thesis_like(3000, 21)


def _files(tmp_path: Path, rows: np.ndarray, lines: list[bytes], file_rows=None):
    log = tmp_path / "dev.log"
    log.write_bytes(b"garbage\r\n" + b"".join(lines))
    data = write_rows(tmp_path / "rows.txt", rows if file_rows is None else file_rows)
    return log, data


def test_agreement(tmp_path: Path, run_cli, rows) -> None:
    log, data = _files(tmp_path, rows, report_lines(rows, 12))
    rc, out, err = run_cli("check", log, data, "--fs", "100")
    assert rc == 0, out + err
    assert "compared exactly 72, exact 72" in out and "OK" in out
    rel = float(out.split("reference: ")[1].split()[0])
    assert rel <= 1e-12


def test_agreement_at_15_levels_on_generated_rows(tmp_path: Path, run_cli) -> None:
    data = tmp_path / "gen.txt"
    assert run_cli("gen", "-n", 40_000, "--seed", 4, "--kind", "walk", "-o", data)[0] == 0
    codes = np.loadtxt(data, dtype=int)
    log = tmp_path / "dev.log"
    log.write_bytes(b"".join(report_lines(codes, 15, seq=65535)))
    rc, out, _ = run_cli("check", log, data)
    assert rc == 0 and "compared exactly 90, exact 90" in out


def test_acc_off_by_one_fails(tmp_path: Path, run_cli, rows) -> None:
    def tweak(ch, k, pairs, acc, flags):
        return pairs, acc + (1 if (ch, k) == ("gx", 3) else 0), flags

    log, data = _files(tmp_path, rows, report_lines(rows, 12, tweak=tweak))
    rc, out, _ = run_cli("check", log, data)
    assert rc == 1
    assert "exact 71" in out and "MISMATCH: 1 problem" in out
    assert "gx level 3:" in out and "off by +1" in out


def test_flags(tmp_path: Path, run_cli, rows) -> None:
    def range_flag(ch, k, pairs, acc, flags):
        return (pairs, 2**48 - 1, 0x03) if (ch, k) == ("az", 10) else (pairs, acc, flags)

    log, data = _files(tmp_path, rows, report_lines(rows, 12, tweak=range_flag))
    rc, out, _ = run_cli("check", log, data)
    assert rc == 0 and "flagged (not compared) 1" in out and "az level 10 sat+range" in out

    def false_sat(ch, k, pairs, acc, flags):
        return (pairs, 2**48 - 1, 0x01) if (ch, k) == ("ay", 0) else (pairs, acc, flags)

    log, data = _files(tmp_path, rows, report_lines(rows, 12, tweak=false_sat))
    rc, out, _ = run_cli("check", log, data)
    assert rc == 1 and "ay level 0: SAT flag set with acc 281474976710655 (0xFFFFFFFFFFFF) but the exact sum is" in out


def test_saturation_is_a_lower_bound(tmp_path: Path, run_cli) -> None:
    """Full-scale square wave of half period 32: at level 5 the exact sum passes
    2^40 - 1 after 958 pairs, so a 40-bit accumulator saturates there."""
    rows = np.zeros((33_000, 7), dtype=int)
    rows[(np.arange(33_000) // 32) % 2 == 1, :6] = 1023
    assert exact_acc([int(v) for v in rows[:, 0]], 32, 1030) == 1030 * (32 * 1023) ** 2 > 2**40

    def sat40(ch, k, pairs, acc, flags):
        return (pairs, 2**40 - 1, 0x01) if (ch, k) in (("ax", 5), ("gz", 5)) else (pairs, acc, flags)

    log, data = _files(tmp_path, rows, report_lines(rows, 6, tweak=sat40))
    rc, out, _ = run_cli("check", log, data)
    assert rc == 0, out
    assert "flagged (not compared) 2" in out and "ax level 5 sat, gz level 5 sat" in out

    def wrong_value(ch, k, pairs, acc, flags):
        return (pairs, 2**44, 0x01) if (ch, k) == ("ax", 5) else (pairs, acc, flags)

    log, data = _files(tmp_path, rows, report_lines(rows, 6, tweak=wrong_value))
    rc, out, _ = run_cli("check", log, data)
    assert rc == 1 and "a saturated acc is 2^40-1 or 2^48-1" in out


def test_header_problems(tmp_path: Path, run_cli, rows) -> None:
    log, data = _files(tmp_path, rows, report_lines(rows, 12, drops=2))
    rc, out, _ = run_cli("check", log, data)
    assert rc == 1 and "drops=2" in out

    log, data = _files(tmp_path, rows, report_lines(rows, 12), file_rows=rows[:2000])
    rc, out, _ = run_cli("check", log, data)
    assert rc == 1 and "n=3000 samples but the file has only 2000 rows" in out
    assert "covers 3000 rows, the file has only 2000" in out

    log, data = _files(tmp_path, rows, report_lines(rows, 12))
    rc, out, _ = run_cli("check", log, data, "--fs", "200")
    assert rc == 1 and "fs=100 Hz, expected 200 Hz" in out


def test_rows_newer_than_the_header_while_running(tmp_path: Path, run_cli, rows) -> None:
    log, data = _files(tmp_path, rows, report_lines(rows, 12, header_n=2900))
    rc, out, _ = run_cli("check", log, data)
    assert rc == 0, out


def test_pairs_must_follow_n_in_a_stopped_run(tmp_path: Path, run_cli, rows) -> None:
    codes = [int(v) for v in rows[:, 4]]

    def fewer(ch, k, pairs, acc, flags):
        if (ch, k) == ("gy", 2):
            return pairs - 1, exact_acc(codes, 4, pairs - 1), flags
        return pairs, acc, flags

    log, data = _files(tmp_path, rows, report_lines(rows, 12, tweak=fewer))
    rc, out, err = run_cli("check", log, data)
    assert rc == 1 and "gy level 2: pairs 748 < floor(n/m) - 1 = 749" in err  # refused by the decoder


def test_bad_input(tmp_path: Path, run_cli, rows) -> None:
    log, data = _files(tmp_path, rows, report_lines(rows, 12))
    rc, out, err = run_cli("check", log, tmp_path / "missing.txt")
    assert rc == 2 and err.count("\n") == 1 and "cannot read" in err and "missing.txt" in err
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2 3 4 5 6 7\n1 2 3\n")
    rc, out, err = run_cli("check", log, bad)
    assert rc == 2 and err.count("\n") == 1 and "bad.txt: line 2: 3 columns, expected 7" in err
    empty = tmp_path / "empty.log"
    empty.write_bytes(b"")
    rc, out, err = run_cli("check", empty, data)
    assert rc == 1 and "no complete report" in err


def test_each_row_is_held_to_its_accumulator_width(tmp_path: Path, run_cli) -> None:
    """With `acc48=11` (the ATmega168), levels below 11 have 40-bit
    accumulators.  Full-scale steps every 512 samples put level 9's exact
    sum (5 * (1023*512)^2) above 2^40 - 1: the device must send SAT with
    acc = 2^40 - 1 there; an unflagged exact value is a mismatch, and so is
    a SAT row showing the 48-bit maximum."""
    n = 3072
    codes = np.where((np.arange(n) >> 9) & 1, 1023, 0)
    rows = np.column_stack([codes] * 6 + [np.full(n, 63)])
    true9 = 5 * (1023 * 512) ** 2
    assert true9 > 2**40 - 1

    def saturate_40(ch, k, pairs, acc, flags):
        if k < 11 and acc >= 2**40 - 1:
            return pairs, 2**40 - 1, 0x01
        return pairs, acc, flags

    log, data = _files(tmp_path, rows, report_lines(rows, 12, tweak=saturate_40, extra=",acc48=11"), file_rows=rows)
    rc, out, _ = run_cli("check", log, data)
    assert rc == 0, out
    assert "ax level 9 sat" in out

    log, data = _files(tmp_path, rows, report_lines(rows, 12, extra=",acc48=11"), file_rows=rows)
    rc, out, _ = run_cli("check", log, data)
    assert rc == 1 and "ax level 9: SAT flag clear" in out

    def saturate_48(ch, k, pairs, acc, flags):
        return (pairs, 2**48 - 1, 0x01) if k == 9 else saturate_40(ch, k, pairs, acc, flags)

    log, data = _files(tmp_path, rows, report_lines(rows, 12, tweak=saturate_48, extra=",acc48=11"), file_rows=rows)
    rc, out, _ = run_cli("check", log, data)
    assert rc == 1 and "ax level 9: SAT flag set" in out
