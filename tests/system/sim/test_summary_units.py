"""The summary a person reads, from the real firmware in simavr: in physical
units (the default) and in counts (`units counts`), last in the report, and
recomputed by `imu-allan check` from the same report's integers; a summary
value changed (with its line CRC made good again) is caught."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import cli

from imu_allan.device.framing import crc16

N = 8000
FS = 100


def _simulate(run, tmp_path: Path, name: str, uart: str | None, n: int = N) -> "object":
    r = run(name)
    cli("gen", "-n", str(n), "--fs", str(FS), "--seed", "7", "-o", str(r.rows))
    uart_in = None
    if uart is not None:
        uart_in = tmp_path / f"{name}.uart"
        uart_in.write_text(uart)
    stats = r.simulate(fs=FS, uart_in=uart_in)
    assert stats["device_drops"] == 0
    return r


def _last_report(log: str) -> list[str]:
    lines = [ln for ln in log.splitlines() if ln.startswith("$")]
    h = max(i for i, ln in enumerate(lines) if ln.startswith("$H,"))
    return lines[h:]


def test_summary_in_phys_is_last_and_checked(run, tmp_path: Path) -> None:
    r = _simulate(run, tmp_path, "phys", None, n=33000)  # 2^15 and more: all 15 levels have pairs
    out = r.check(fs=FS)
    assert "OK" in out and "summary terms (N, B, +-% in phys units): 18" in out, out
    rep = _last_report(r.log.read_text())
    kinds = [ln[1] for ln in rep]
    # H, L..., T..., V, S..., E: the summary last, right before E
    first_s = kinds.index("S")
    assert kinds[-1] == "E" and set(kinds[first_s:-1]) == {"S"}
    assert kinds[first_s - 1] == "V" and kinds[first_s - 7 : first_s - 1] == ["T"] * 6
    summary = rep[first_s:]
    # 15 levels: the last 23 lines (an 80x24 terminal) are exactly the summary and E
    assert len(summary) == 23 and all(len(ln) <= 80 for ln in summary)
    assert "Allan deviation by tau (s): accel mg at +-1.5 g, gyro deg/s" in summary[0]
    assert re.search(r"N at [0-9.]+ s \+-[0-9.]+%: m/s/rt\(h\), deg/rt\(h\); B: mg, deg/h", summary[-6])
    assert "units=phys" in rep[0]


def test_units_counts_summary_in_counts_and_checked(run, tmp_path: Path) -> None:
    r = _simulate(run, tmp_path, "counts", "50\tunits counts\\r\n")
    out = r.check(fs=FS)
    assert "OK" in out and "in counts units" in out, out
    rep = _last_report(r.log.read_text())
    assert "units=counts" in rep[0]
    summary = [ln for ln in rep if ln.startswith("$S,")]
    assert "Allan deviation by tau (s): ADC counts" in summary[0]
    assert "count rt(s); B: counts" in summary[-5]


def _refrane(line: str, body: str) -> str:
    return f"${body}*{crc16(body.encode()):04X}"


def test_a_changed_summary_value_is_caught(run, tmp_path: Path) -> None:
    r = _simulate(run, tmp_path, "tamper", None)
    text = r.log.read_text()
    lines = text.splitlines(keepends=True)
    # the last report's B row: change gx's B (a value check recomputes)
    idx = max(i for i, ln in enumerate(lines) if re.match(r"\$S,\d+, +B ", ln))
    body = lines[idx][1 : lines[idx].index("*")]
    cells = body.split(",", 2)[2].split()
    cells[4] = f"{float(cells[4]) * 1.02:.3g}"
    new = ",".join(body.split(",", 2)[:2]) + "," + "".join(f"{c:>9}" for c in cells)
    lines[idx] = _refrane(lines[idx], new) + "\r\n"
    r.log.write_text("".join(lines))
    out = cli("check", str(r.log), str(r.rows), "--fs", str(FS), check=False)
    assert out.returncode != 0 and "gx B: summary shows" in out.stdout, out.stdout


def _record(bits: int) -> bytes:
    """A version-2 EEPROM record (firmware/settings.c, built here
    independently): 100 Hz, interval 60, mode allan, range 2 g, then the
    echo byte (bit 0 echo, bit 1 units counts), CRC-16/MODBUS high byte first."""
    body = bytes([2]) + (100).to_bytes(2, "little") + (60).to_bytes(2, "little") + bytes([0, 1, bits])
    crc = 0xFFFF
    for b in body:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return body + bytes([crc >> 8, crc & 0xFF])


@pytest.mark.parametrize(
    "bits,cfg,units",
    [
        (1, "saved", "phys"),  # saved before `units`: phys
        (3, "saved", "counts"),  # echo on, units counts
        (5, "corrupt", "phys"),
    ],
)  # a bit no setting has
def test_units_saved_in_the_echo_byte(run, tmp_path: Path, bits: int, cfg: str, units: str) -> None:
    import subprocess

    from conftest import ELF, SIM

    r = run(f"ee-{bits}")
    cli("gen", "-n", "3000", "--seed", "5", "-o", str(r.rows))
    ee = tmp_path / "ee.bin"
    ee.write_bytes(_record(bits))
    proc = subprocess.run(
        [
            str(SIM),
            "--adc",
            str(r.rows),
            "-o",
            str(r.log),
            "--stats-json",
            str(r.stats_file),
            "--eeprom",
            str(ee),
            str(ELF),
        ],
        capture_output=True,
        text=True,
        errors="replace",
    )
    assert proc.returncode == 0, proc.stderr
    head = r.decode()["header"]
    assert head["cfg"] == cfg and head["extra"]["units"] == units
    assert head["range_g"] == ("2" if cfg == "saved" else "1.5")
    out = r.check(fs=100)
    assert "OK" in out and f"in {units} units" in out, out
