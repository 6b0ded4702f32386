"""`make sim-test`: the firmware in simavr on synthetic IMU streams.  Each
scenario's on-device Allan results must equal the float64 reference over
the same rows exactly (`imu-allan check`), with no sample dropped."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import cli

from imu_allan.channels import RATES_HZ

RATES = list(RATES_HZ)  # every rate the device offers


def simulate_and_check(r, n: int, fs: int, uart_in: Path | None = None) -> tuple[dict, dict]:
    stats = r.simulate(fs=fs, uart_in=uart_in)
    out = r.check(fs=fs)
    assert "OK" in out, out
    report = r.decode()
    head = report["header"]
    assert head["n"] == n and head["drops"] == 0 and head["fs_hz"] == fs
    assert stats["device_drops"] == 0 and stats["extra_scans"] == 0
    assert stats["rows_consumed"] == n
    # Every one of the 6 x 15 rows was compared exactly or carries a flag.
    assert len(report["rows"]) == 6 * head["levels"]
    return stats, report


@pytest.mark.parametrize(
    "kind,fs,n",
    [
        ("noise", 100, 30000),  # the thesis noise model: white + Gauss-Markov + RRW
        ("walk", 200, 40000),  # random walks over the whole code range
        ("drift", 100, 30000),  # noise plus linear drift
        ("clip", 250, 30000),  # hits 0 and 1023 all the time
        ("square", 100, 20000),  # full-scale square waves
    ],
)
def test_kind_is_exact(run, kind: str, fs: int, n: int) -> None:
    r = run(kind)
    cli("gen", "-n", str(n), "--fs", str(fs), "--kind", kind, "--seed", "7", "-o", str(r.rows))
    _, report = simulate_and_check(r, n, fs)
    if kind == "clip":
        clips = report["header"]["clips"]
        rows = np.loadtxt(r.rows, dtype=int, comments="#")
        for i, ch in enumerate(["ax", "ay", "az", "gx", "gy", "gz", "temp"]):
            expect = int(np.count_nonzero((rows[:, i] == 0) | (rows[:, i] == 1023)))
            assert clips[ch] == min(expect, 65535), ch


@pytest.mark.parametrize("fs", RATES)
def test_every_sample_rate_is_exact(run, fs: int) -> None:
    r = run(f"rate{fs}")
    n = 12000
    cli("gen", "-n", str(n), "--fs", str(fs), "--seed", str(fs), "-o", str(r.rows))
    stats, report = simulate_and_check(r, n, fs)
    # The device sampled at fs: n samples took n / fs s of device time,
    # plus boot, commands and the final report (a few seconds at most).
    assert n / fs <= stats["sim_seconds"] <= n / fs + 3.0


def test_reports_at_the_top_rate_cost_no_sample(run, tmp_path: Path) -> None:
    """At the highest rate (1500 Hz: a set every 6667 cycles, a ring of 3)
    with a report every second, the report's summary and noise terms read
    every level: the engine's waiting pairs are taken a piece at a time
    between sets, so no set is dropped and the results stay exact."""
    r = run("top-rate-reports")
    fs, n = max(RATES), 1 << 15
    cli("gen", "-n", str(n), "--fs", str(fs), "--seed", "1501", "-o", str(r.rows))
    uart = tmp_path / "uart.txt"
    uart.write_text("0\tinterval 1\\r\n")
    simulate_and_check(r, n, fs, uart_in=uart)
    assert r.log.read_bytes().count(b"$E,") >= n // fs - 1  # a report every second


def test_start_count_ends_sampling_with_its_last_set(run, tmp_path: Path) -> None:
    """The harness runs `start <rows>`; a `status` sent as the last set is
    taken must already say run=0 (the tick stops as the last scan starts,
    not one sample period later: at 50 Hz that period was 20 ms)."""
    r = run("count_end")
    n = 200
    cli("gen", "-n", str(n), "--fs", "50", "--seed", "5", "-o", str(r.rows))
    uart = tmp_path / "status.txt"
    uart.write_text(f"{n}\tstatus\\r\n")
    simulate_and_check(r, n, 50, uart_in=uart)
    text = r.log.read_bytes()
    assert b"$ok status run=0 " in text and b"$ok status run=1 " not in text, text[-400:]


def test_saturation_is_flagged_not_wrong(run) -> None:
    """Full-scale steps every 1024 samples: differences of 1023*m at levels
    7 and up overflow the ATmega168's 40-bit accumulators (levels 0..10)
    within a few dozen pairs, never the 48-bit ones (11..14) in this run.
    `check` compares every unflagged row exactly and verifies every SAT flag
    against the exact sum; here we also see which levels saturated."""
    r = run("saturate")
    n = 70000
    i = np.arange(n)
    codes = np.where((i >> 10) & 1, 1023, 0)
    rows = np.column_stack([codes] * 6 + [np.full(n, 63)])
    np.savetxt(r.rows, rows, fmt="%d", delimiter="\t")
    _, report = simulate_and_check(r, n, 100)
    sat = {row["level"] for row in report["rows"] if "sat" in row["flags"]}
    assert sat and sat <= set(range(7, 11)), sat


def test_reports_requested_mid_run_and_periodic_ones_change_nothing(run, tmp_path: Path) -> None:
    """Reports while sampling (asked for, and 60 s after the previous one)
    must not disturb the results: the final report is still exact."""
    r = run("midrun")
    n = 15000
    cli("gen", "-n", str(n), "--fs", "100", "--seed", "11", "-o", str(r.rows))
    uart = tmp_path / "uart.txt"
    uart.write_text("1000\treport\\r\n5000\treport\\r\n5001\treport\\r\n")
    simulate_and_check(r, n, 100, uart_in=uart)
    log = r.log.read_text()
    # Asked for at 1000, 5000 and 5001 (held until the one before ends);
    # periodic 6000 samples after the previous report's header, i.e. at
    # about 11040; the harness's final one.
    assert log.count("$E,") == 5, log.count("$E,")


def test_long_run_of_2_20_samples(run) -> None:
    r = run("long")
    n = 1 << 20
    cli("gen", "-n", str(n), "--fs", "1000", "--seed", "20", "-o", str(r.rows))
    _, report = simulate_and_check(r, n, 1000)
    top = [row for row in report["rows"] if row["level"] == 14]
    assert all(row["pairs"] == n // 16384 - 1 for row in top)


def test_noisy_rx_at_full_rate_loses_nothing(run, tmp_path: Path) -> None:
    """1 kHz for 20 s while the radio delivers random bytes, overlong lines
    and valid commands (status, help, interval, report, bad arguments): every
    line gets its reply or is dropped whole, no sample is lost, and the
    Allan results are still exact."""
    r = run("noisy")
    n = 20000
    cli("gen", "-n", str(n), "--fs", "1000", "--seed", "13", "-o", str(r.rows))
    rng = np.random.default_rng(13)
    lines = []
    # No letters in the noise, so it can never spell a command.
    alphabet = [b for b in range(256) if not chr(b).isalpha()]
    for i in range(200, n - 500, 450):
        noise = bytes(rng.choice(alphabet, size=int(rng.integers(1, 40))).tolist())
        lines.append(f"{i}\t" + "".join(f"\\x{b:02x}" for b in noise) + "\\r")
        lines.append(f"{i + 50}\t" + "x" * int(rng.integers(17, 60)) + "\\r")  # overlong
        cmd = ["status", "help", "interval 5", "report", "rate 300", "mode fast", "range 3"][(i // 450) % 7]
        lines.append(f"{i + 100}\t{cmd}\\r")
    uart = tmp_path / "noisy.txt"
    uart.write_text("\n".join(lines) + "\n")
    simulate_and_check(r, n, 1000, uart_in=uart)
    text = r.log.read_bytes()
    assert text.count(b"$ok status") >= 5 and text.count(b": line too long; 16 chars*") >= 30


def _contiguous_slice(rows: np.ndarray, part: np.ndarray) -> int:
    """Index where `part` sits inside `rows` as one unbroken run (or fail)."""
    assert len(part) > 0
    starts = np.flatnonzero((rows[:, :] == part[0]).all(axis=1))
    for s in starts:
        if s + len(part) <= len(rows) and np.array_equal(rows[s : s + len(part)], part):
            return int(s)
    raise AssertionError("the captured rows are not an unbroken run of the input")


def _assert_rows_from_switch_to_switch_back(r, tmp_path: Path, n: int) -> None:
    """`imu-allan rows` on the capture exits 0 and gives an unbroken run of the
    input rows from the switch to a stream mode (row 100) to the switch back
    (row n - 200)."""
    extracted = tmp_path / "extracted.tsv"
    proc = cli("rows", str(r.log), "-o", str(extracted), check=False)
    assert proc.returncode == 0, proc.stderr
    rows = np.loadtxt(r.rows, dtype=int, comments="#")
    got = np.loadtxt(extracted, dtype=int, comments="#")
    start = _contiguous_slice(rows, got)
    assert 100 <= start <= 110 and start + len(got) >= n - 210, (start, len(got))


@pytest.mark.parametrize("mode,fs", [("raw", 100), ("binary", 500), ("both", 50)])
def test_output_modes_carry_every_sample(run, tmp_path: Path, mode: str, fs: int) -> None:
    """Switch to an output mode during the run and back to allan near its
    end: the capture's rows (raw text, or binary frames) must be an unbroken
    run of the input rows with nothing lost (count lines and sequence
    numbers agree), and the Allan results stay exact throughout."""
    r = run(f"mode-{mode}")
    n = 6000 if fs <= 100 else 12000
    cli("gen", "-n", str(n), "--fs", str(fs), "--seed", str(fs + 1), "-o", str(r.rows))
    uart = tmp_path / "uart.txt"
    uart.write_text(f"100\tmode {mode}\\r\n{n - 200}\tmode allan\\r\n")
    simulate_and_check(r, n, fs, uart_in=uart)
    _assert_rows_from_switch_to_switch_back(r, tmp_path, n)


def test_typing_in_raw_100_hz_costs_no_sample(run, tmp_path: Path) -> None:
    """Mode raw at 100 Hz (the highest rate the link budget allows raw at
    115200 baud) while a person types, a character at a time, with DEL and
    a dropped line: each line's echo ("> ..." CR LF) comes whole between
    two rows, a row between it and its reply, no sample is dropped, the
    rows are an unbroken run of the input, and the Allan results stay
    exact."""
    r = run("raw-typing")
    n, fs = 6000, 100
    cli("gen", "-n", str(n), "--fs", str(fs), "--seed", "251", "-o", str(r.rows))
    typed = [
        ("e", 1),
        ("c", 1),
        ("h", 1),
        ("x", 1),
        ("\\x7f", 1),
        ("o", 1),
        ("\\r", 1),
        ("s", 1),
        ("t", 1),
        ("o", 1),
        ("\\x03", 1),
        ("h", 1),
        ("e", 1),
        ("l", 1),
        ("p", 1),
        ("\\r", 1),
        ("r", 1),
        ("a", 1),
        ("t", 1),
        ("e", 1),
        (" ", 1),
        ("9", 1),
        ("\\r", 1),
    ]
    lines, at = ["100\tmode raw\\r"], 500
    for text, _ in typed:
        lines.append(f"{at}\t{text}")
        at += 20  # a character every 0.2 s
    lines.append(f"{n - 200}\tmode allan\\r")
    uart = tmp_path / "uart.txt"
    uart.write_text("\n".join(lines) + "\n")
    simulate_and_check(r, n, fs, uart_in=uart)
    text = r.log.read_bytes()
    assert b"\r\n> echo\r\n" in text and b"$ok echo=on*" in text
    # Ctrl-C dropped it (1: the harness's); never shown (the echo of a stream
    # mode comes when a line ends), so nothing on the screen to mark
    assert b"> sto\r\n" not in text and b"sto^C" not in text and text.count(b"ok stopped") == 1
    assert b"\r\n> help\r\n" in text and text.count(b"$ok help ") == 15
    assert b"\r\n> rate 9\r\n" in text
    assert b"$error:2 rate: unsupported; 50|100|200|250|500|1000|1250|1500 (Hz)*" in text
    _assert_rows_from_switch_to_switch_back(r, tmp_path, n)


def _settings_record(rate: int, interval: int, mode: int, rng: int, good_crc: bool = True) -> bytes:
    """The EEPROM record of firmware/settings.c, built here independently:
    version 2, rate and interval little-endian, mode, range, echo (on), then
    CRC-16/MODBUS (reflected 0xA001, from 0xFFFF) high byte first."""
    body = bytes([2]) + rate.to_bytes(2, "little") + interval.to_bytes(2, "little") + bytes([mode, rng, 1])
    crc = 0xFFFF
    for b in body:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    if not good_crc:
        crc ^= 0x0100
    return body + bytes([crc >> 8, crc & 0xFF])


@pytest.mark.parametrize("case", ["saved", "corrupt", "blank"])
def test_settings_come_from_eeprom_or_defaults(run, tmp_path: Path, case: str) -> None:
    """A saved record sets rate 250 Hz and range 4 g at power-up; a corrupted
    one (bad CRC) or none gives the defaults, and the header says which."""
    import json
    import subprocess

    from conftest import ELF, SIM

    r = run(f"eeprom-{case}")
    n = 3000
    cli("gen", "-n", str(n), "--seed", "5", "-o", str(r.rows))
    args = [str(SIM), "--adc", str(r.rows), "-o", str(r.log), "--stats-json", str(r.stats_file)]
    if case != "blank":
        ee = tmp_path / "ee.bin"
        ee.write_bytes(_settings_record(250, 5, 0, 2, good_crc=case == "saved"))
        args += ["--eeprom", str(ee)]
    proc = subprocess.run(args + [str(ELF)], capture_output=True, text=True, errors="replace")
    assert proc.returncode == 0, proc.stderr
    head = r.decode()["header"]
    assert head["cfg"] == case
    fs = 250 if case == "saved" else 100
    assert head["fs_hz"] == fs and head["range_g"] == ("4" if case == "saved" else "1.5")
    assert "OK" in r.check(fs=fs)
    assert json.loads(r.stats_file.read_text())["device_drops"] == 0
