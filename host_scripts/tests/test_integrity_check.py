"""The second line of defence behind the CRC-16, on logs of the real firmware: the
report's ``V`` check line (run identity and CRC-16/MODBUS of the H and L
bodies) and the count lines' block CRC over raw rows and binary frames.

The logs come from the firmware ELF run in the simulator harness (imu-sim).
Corruptions are made so that every line keeps a valid CRC-16 (an undetected
line error): either the line CRC is recomputed after the change, or a field
is brute-forced for the values that keep the CRC as sent."""

from __future__ import annotations

import binascii
import os
import random
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import thesis_like, write_rows

from imu_allan.device.capture import decode_stream
from imu_allan.device.records import decode_bytes

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("BUILD", REPO / "build"))
ELF = BUILD / "avr-atmega168" / "imu-allan.elf"
SIM = BUILD / "host" / "imu-sim"
ROWS = 3000


def _modbus(data: bytes) -> int:
    """CRC-16/MODBUS bit by bit, written out here (docs/protocol.md)."""
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return crc


def _line(body: bytes) -> bytes:
    return b"$%s*%04X\r\n" % (body, binascii.crc_hqx(body, 0xFFFF))


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> dict[str, bytes]:
    if not (ELF.is_file() and SIM.is_file()):
        pytest.skip(f"{ELF.name} or imu-sim not built (run 'make firmware sim')")
    d = tmp_path_factory.mktemp("vlogs")
    adc = write_rows(d / "adc.tsv", thesis_like(ROWS, 3))
    out = {}
    for name, uart in (
        ("report", None),
        ("splice", "1000\treport\\r\n1030\treset\\r\n1400\treport\\r\n"),
        ("raw", "0\tmode raw\\r\n"),
        ("binary", "0\tmode binary\\r\n"),
        ("both", "0\tmode both\\r\n1500\treport\\r\n"),
    ):
        cmd = [str(SIM), "--adc", str(adc), "-o", str(d / f"{name}.log")]
        if name == "both":
            cmd += ["--fs", "50"]  # rows and reports share the link up to 50 Hz
        if uart:
            (d / f"{name}.in").write_text(uart)
            cmd += ["--uart-in", str(d / f"{name}.in")]
        subprocess.run(cmd + [str(ELF)], capture_output=True, timeout=120)
        out[name] = (d / f"{name}.log").read_bytes()
    out["adc"] = adc.read_bytes()
    return out


def _bodies(log: bytes) -> list[bytes]:
    return [m.group(1) for m in re.finditer(rb"\$([^*\r\n$]*)\*[0-9A-F]{4}\r\n", log)]


def test_a_real_report_carries_a_check_the_host_verifies(logs) -> None:
    assert _modbus(b"123456789") == 0x4B37
    bodies = _bodies(logs["report"])
    h = [b for b in bodies if b.startswith(b"H,")]
    v = [b for b in bodies if b.startswith(b"V,")]
    assert len(h) == len(v) == 1
    run = re.search(rb",id=(\d+),", h[0]).group(1)
    want = _modbus(b"".join(b for b in bodies if b.startswith((b"H,", b"L,"))))
    assert v[0] == b"V,0,id=%s,crc=%04X" % (run, want)
    res = decode_bytes(logs["report"])
    assert len(res.reports) == 1 and res.errors["report_check_failed"] == 0
    assert res.reports[0].header.extra["id"] == run.decode()


def _swap(log: bytes, old: bytes, new: bytes) -> bytes:
    assert log.count(old) == 1
    return log.replace(old, new)


def test_an_l_change_with_its_line_crc_recomputed_is_refused(logs) -> None:
    """Every kind of single-character change of an L body (digits of pairs,
    acc, flags) with the line CRC made valid again: the V check refuses each."""
    log = logs["report"]
    rows = [b for b in _bodies(log) if b.startswith(b"L,")]
    rng = random.Random(10)
    tried = accepted = 0
    for _ in range(300):
        body = rng.choice(rows)
        head, tail = body.rsplit(b",", 3)[0], body.rsplit(b",", 3)[1:]
        f = rng.randrange(3)
        field = bytearray(tail[f])
        i = rng.randrange(len(field))
        alphabet = b"0123456789" if f == 0 else b"0123456789ABCDEF"
        field[i] = rng.choice([c for c in alphabet if c != field[i]])
        tail[f] = bytes(field)
        new = b",".join([head] + tail)
        bad = _swap(log, _line(body), _line(new))
        res = decode_bytes(bad)
        tried += 1
        accepted += len(res.reports)
        assert res.errors["report_check_failed"] + res.errors["unparsable"] == 1
    assert tried == 300 and accepted == 0


def test_crc16_preserving_acc_changes_are_refused(logs) -> None:
    """The last 5 hex digits of ``acc`` brute-forced (2^20 values) on 8 rows:
    every value that keeps the line's CRC-16 as sent is refused by V."""
    log = logs["report"]
    rows = [b for b in _bodies(log) if b.startswith(b"L,")]
    tried = accepted = 0
    for body in rows[::11][:8]:
        head, acc, flags = body.rsplit(b",", 2)
        prefix = head + b"," + acc[:7]
        want = binascii.crc_hqx(body, 0xFFFF)
        state = binascii.crc_hqx(prefix, 0xFFFF)
        suffix = b"," + flags
        keep = [
            v
            for v in (b"%05X" % k for k in range(1 << 20))
            if binascii.crc_hqx(suffix, binascii.crc_hqx(v, state)) == want and v != acc[7:]
        ]
        for v in keep:
            new = prefix + v + suffix
            assert _line(new) == b"$%s*%04X\r\n" % (new, want)  # the line CRC still holds
            res = decode_bytes(_swap(log, _line(body), _line(new)))
            tried += 1
            accepted += len(res.reports)
            assert res.errors["report_check_failed"] == 1
    assert tried >= 64 and accepted == 0


def _relabel(lines: list[bytes], seq: bytes) -> list[bytes]:
    return [re.sub(rb"^([A-Z]),\d+,", rb"\1," + seq + b",", b) for b in lines]


def test_runs_spliced_across_a_reset_are_refused(logs) -> None:
    log = logs["splice"]
    bodies = _bodies(log)
    h = [i for i, b in enumerate(bodies) if b.startswith(b"H,")]
    first, second = bodies[h[0] : h[1]], bodies[h[1] : h[2]]
    cut = [b for b in first if b.startswith(b"L,")]
    assert 0 < len(cut) < 90 and b"ok reset" in first  # the first report was cut by the reset
    intact = decode_bytes(log)
    assert [r.seq for r in intact.reports] == [1, 2]
    # a splice of two runs: the second header and the rows after it lost
    rest = [b for b in second[1 + len(cut) :]]
    spliced = b"".join(_line(b) for b in bodies[: h[0]] + [first[0]] + cut + rest)
    assert decode_bytes(spliced).reports == []
    # worse: the later lines also carry the first report's seq (a restart of seq)
    tail = _relabel(rest, b"0")
    res = decode_bytes(b"".join(_line(b) for b in [first[0]] + cut + tail))
    assert res.reports == [] and res.errors["report_check_failed"] == 1
    assert "id=" in res.refused[0]
    # and even with V's id made the header's: the CRC does not hold
    run = re.search(rb",id=(\d+),", first[0]).group(1)
    tail = [re.sub(rb"id=\d+", b"id=" + run, b) if b.startswith(b"V,") else b for b in tail]
    res = decode_bytes(b"".join(_line(b) for b in [first[0]] + cut + tail))
    assert res.reports == [] and res.errors["report_check_failed"] == 1
    assert "crc=" in res.refused[0]


def test_a_report_without_its_check_is_refused_but_old_firmware_is_accepted(logs) -> None:
    bodies = _bodies(logs["report"])
    no_v = [b for b in bodies if not b.startswith(b"V,")]
    res = decode_bytes(b"".join(_line(b) for b in no_v))
    assert res.reports == [] and res.errors["report_check_failed"] == 1
    old = [re.sub(rb",id=\d+", b"", b) for b in no_v]  # the first protocol-1 firmware
    res = decode_bytes(b"".join(_line(b) for b in old))
    assert len(res.reports) == 1 and res.errors["report_check_failed"] == 0
    assert res.reports[0].rows == decode_bytes(logs["report"]).reports[0].rows


def _rows_cli(tmp_path: Path, log: bytes) -> tuple[int, np.ndarray, str]:
    src = tmp_path / "cap.log"
    src.write_bytes(log)
    out = tmp_path / "rows.tsv"
    env = dict(os.environ, PYTHONPATH=str(REPO / "host_scripts"))
    p = subprocess.run(
        [sys.executable, "-m", "imu_allan.cli", "rows", str(src), "-o", str(out)],
        capture_output=True,
        text=True,
        env=env,
    )
    got = np.loadtxt(out, dtype=np.int64, comments="#", ndmin=2) if out.is_file() else None
    return p.returncode, got, p.stderr


def _truth(logs) -> np.ndarray:
    return np.loadtxt(logs["adc"].decode().splitlines(), dtype=np.int64, comments="#", ndmin=2)


@pytest.mark.parametrize("mode", ["raw", "binary"])
def test_intact_captures_are_written_whole_and_verified(logs, tmp_path, mode) -> None:
    rc, got, err = _rows_cli(tmp_path, logs[mode])
    assert rc == 0, err
    assert np.array_equal(got, _truth(logs))
    assert f"{ROWS // 100} blocks verified" in err and "0 rows dropped" in err


def test_rows_and_reports_of_mode_both_are_all_verified(logs) -> None:
    cap = decode_stream(logs["both"], line_start=True)
    assert [r.seq for r in cap.reports] == [0, 1] and cap.counts["report_check_failed"] == 0
    assert cap.counts["blocks_verified"] == ROWS // 100 and cap.counts["blocks_bad"] == 0
    assert np.array_equal(cap.samples.T.astype(np.int64), _truth(logs))


def test_a_changed_raw_digit_drops_its_block(logs, tmp_path) -> None:
    log = logs["raw"]
    starts = [m.start() for m in re.finditer(rb"\n\d", log)]
    at = starts[1234] + 1  # the first digit of a row in the 13th block
    d = log[at]
    bad = log[:at] + bytes([d + 1 if d < 0x39 else d - 1]) + log[at + 1 :]
    dec = decode_stream(bad)
    assert dec.counts["bad_rows"] == 0 and dec.counts["blocks_bad"] == 1  # the row still parses
    rc, got, err = _rows_cli(tmp_path, bad)
    assert rc == 3 and "100 rows dropped" in err and "1 bad blocks" in err
    assert np.array_equal(got, np.delete(_truth(logs), np.s_[1200:1300], axis=0))


def test_a_lost_raw_row_drops_its_block(logs, tmp_path) -> None:
    log = logs["raw"]
    starts = [m.start() + 1 for m in re.finditer(rb"\n\d", log)]
    bad = log[: starts[555]] + log[starts[556] :]
    rc, got, err = _rows_cli(tmp_path, bad)
    assert rc == 3 and "99 rows dropped" in err
    assert np.array_equal(got, np.delete(_truth(logs), np.s_[500:600], axis=0))


def test_a_binary_frame_changed_with_its_own_crc_drops_its_block(logs, tmp_path) -> None:
    log = bytearray(logs["binary"])
    frames = [m.start() for m in re.finditer(rb"\xa5", bytes(log))]
    at = next(p for p in frames if p > len(log) // 2)
    body = bytearray(log[at + 1 : at + 11])
    body[3] ^= 0x01  # a code's low bit
    c = binascii.crc_hqx(bytes(body), 0xFFFF)
    log[at + 1 : at + 13] = bytes(body) + bytes([c >> 8, c & 0xFF])
    rc, got, err = _rows_cli(tmp_path, bytes(log))
    assert rc == 3 and "100 rows dropped" in err and "1 bad blocks" in err
    assert got.shape[0] == ROWS - 100


def test_old_count_lines_are_written_unverified(logs, tmp_path) -> None:
    old = re.sub(rb"\$(C,\d+,\d+),[0-9A-F]{4}\*[0-9A-F]{4}\r\n", lambda m: _line(m.group(1)), logs["raw"])
    rc, got, err = _rows_cli(tmp_path, old)
    assert rc == 0 and np.array_equal(got, _truth(logs))
    assert "unverified" in err and "no block CRC" in err
