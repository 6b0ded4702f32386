"""Integrity scenarios (issue 10) on the real firmware in simavr: commands
of every allowed length arrive whole at every rate and in every mode with
output running; a line holding a byte no command holds is refused whole; a
report never starts in a state it cannot describe; an EEPROM record the
link cannot carry is not loaded.  Each run is also checked exactly
(`imu-allan check`) with no sample dropped."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import ELF, SIM, cli
from test_scenarios import RATES, _settings_record, simulate_and_check

# The longest lines the device accepts (16 characters), each with the reply
# it must get; none of them changes the run.
LONG_COMMANDS = [
    ("interval    3600", b"$ok interval=3600*"),
    ("interval\t\t\t\t3600", b"$ok interval=3600*"),
    ("   status       ", b"$ok status "),
]


def _crc_ccitt(data: bytes) -> int:
    reg = 0xFFFF
    for b in data:
        reg ^= b << 8
        for _ in range(8):
            reg = ((reg << 1) ^ 0x1021) & 0xFFFF if reg & 0x8000 else (reg << 1) & 0xFFFF
    return reg


def _text_of(log: bytes) -> bytes:
    """The capture without its binary frames (docs/protocol.md: a frame,
    0xA5 and 12 bytes whose CRC holds, may sit inside a text line)."""
    out, i = bytearray(), 0
    while i < len(log):
        if (
            log[i] == 0xA5
            and i + 13 <= len(log)
            and _crc_ccitt(log[i + 1 : i + 11]) == int.from_bytes(log[i + 11 : i + 13], "big")
        ):
            i += 13
            continue
        out.append(log[i])
        i += 1
    return bytes(out)


def _storm(n: int, seed: int, first: int, last: int, extra: list[str]) -> tuple[str, dict[bytes, int]]:
    """Long commands at random phases between rows first and last, one at a
    time (the next well after the previous reply)."""
    rng = np.random.default_rng(seed)
    lines, want = list(extra), {}
    i = first
    while True:
        i += int(rng.integers(150, 450))
        if i >= last:
            break
        text, reply = LONG_COMMANDS[int(rng.integers(0, len(LONG_COMMANDS)))]
        lines.append(f"{i}\t" + text.replace("\t", "\\t") + "\\r")
        want[reply] = want.get(reply, 0) + 1
    return "\n".join(sorted(lines, key=lambda s: int(s.split("\t")[0]))) + "\n", want


@pytest.mark.parametrize("mode,fs", [("allan", fs) for fs in RATES] + [("raw", 100), ("binary", 500), ("both", 50)])
def test_long_commands_at_random_phases_lose_no_byte(run, tmp_path: Path, mode: str, fs: int) -> None:
    r = run(f"storm-{mode}-{fs}")
    n = 6000 if fs <= 100 else 9000
    cli("gen", "-n", str(n), "--fs", str(fs), "--seed", str(fs + 7), "-o", str(r.rows))
    extra = [] if mode == "allan" else [f"50\tmode {mode}\\r", f"{n - 150}\tmode allan\\r"]
    text, want = _storm(n, fs, 100, n - 300, extra)
    uart = tmp_path / "uart.txt"
    uart.write_text(text)
    simulate_and_check(r, n, fs, uart_in=uart)
    log = _text_of(r.log.read_bytes())
    assert b"$error:" not in log, re.findall(rb"\$error:[^*]*", log)
    for reply, count in want.items():
        assert log.count(reply) >= count, (reply, log.count(reply), count)


def test_line_with_a_nul_or_control_byte_is_refused_whole(run, tmp_path: Path) -> None:
    """`reset\\x00xyz` must not reset: every such line gets `error:6` and
    nothing changes (the run stays whole and exact, the rate unchanged)."""
    r = run("nul")
    n = 4000
    cli("gen", "-n", str(n), "--fs", "100", "--seed", "17", "-o", str(r.rows))
    bad = [
        "reset\\x00xyz",
        "range 6\\x00!",
        "interval 5\\x00000",
        "rate 250\\x00 junk",
        "status\\x01",
        "help\\xff",
        "\\x00",
        "stop\\x1a",
    ]
    dropped = ["stop\\x1b", "stop\\x03"]  # Esc, Ctrl-C: the line is dropped, no reply
    uart = tmp_path / "uart.txt"
    uart.write_text("".join(f"{500 + 300 * i}\t{b}\\r\n" for i, b in enumerate(bad + dropped)))
    simulate_and_check(r, n, 100, uart_in=uart)
    log = r.log.read_bytes()
    log = log[log.index(b"$ok started") :]  # after the harness's own commands
    assert log.count(b"$error:6 ") == len(bad)
    for word in (b"$ok reset", b"$ok range", b"$ok interval", b"$ok rate", b"$ok status", b"$ok help", b"$ok stopped"):
        assert word not in log


def test_report_race_header_describes_its_state(run, tmp_path: Path) -> None:
    """The header race: a report that starts before the first sample of a
    run said `temp=-:63:63`.  Every header's temp is `-` or mean:min:max."""
    r = run("race")
    n = 12000
    cli("gen", "-n", str(n), "--fs", "50", "--seed", "2", "-o", str(r.rows))
    uart = tmp_path / "uart.txt"
    uart.write_text(
        "1750\t"
        + "\\r" * 48
        + "reset\\rreport\\r\n"
        + "".join(f"{2000 + 97 * i}\treset\\rreport\\r\n" for i in range(40))
    )
    # The resets make the final report's n differ from the rows: the harness
    # then ends on its timeout (exit 3), which is expected here.
    proc = subprocess.run(
        [
            str(SIM),
            "--adc",
            str(r.rows),
            "-o",
            str(r.log),
            "--fs",
            "50",
            "--uart-in",
            str(uart),
            "--timeout",
            "1",
            str(ELF),
        ],
        capture_output=True,
        text=True,
        errors="replace",
    )
    assert proc.returncode in (0, 3), proc.stderr
    log = r.log.read_bytes()
    temps = re.findall(rb"\$H,[^*]*,temp=([^,*]*)", log)
    assert len(temps) >= 30
    for t in temps:
        assert t == b"-" or re.fullmatch(rb"\d+\.\d:\d+:\d+", t), t
    ends = log.count(b"$E,")
    assert ends >= 30


@pytest.mark.parametrize("mode,fs", [(1, 1000), (2, 1000), (3, 250)])
def test_infeasible_eeprom_record_loads_defaults(run, tmp_path: Path, mode: int, fs: int) -> None:
    """A record with a valid CRC but a rate/mode pair the link cannot carry
    (raw or binary at 1000 Hz, both at 250 Hz) is not loaded: the defaults
    are, and the header says `cfg=infeasible`."""
    import json
    import subprocess

    from conftest import ELF, SIM

    r = run(f"eeprom-infeasible-{mode}-{fs}")
    n = 2000
    cli("gen", "-n", str(n), "--seed", "6", "-o", str(r.rows))
    ee = tmp_path / "ee.bin"
    ee.write_bytes(_settings_record(fs, 5, mode, 0))
    args = [str(SIM), "--adc", str(r.rows), "-o", str(r.log), "--stats-json", str(r.stats_file), "--eeprom", str(ee)]
    proc = subprocess.run(args + [str(ELF)], capture_output=True, text=True, errors="replace")
    assert proc.returncode == 0, proc.stderr
    head = r.decode()["header"]
    assert head["cfg"] == "infeasible" and head["fs_hz"] == 100
    assert "OK" in r.check(fs=100)
    assert json.loads(r.stats_file.read_text())["device_drops"] == 0


def _reply_storm(n: int, seed: int, mode: str) -> str:
    """`mode <mode>` early, the longest replies (status, help) every 40 to
    120 rows, `mode allan` near the end."""
    rng = np.random.default_rng(seed)
    lines, i = [f"50\tmode {mode}\\r"], 100
    while True:
        i += int(rng.integers(40, 120))
        if i >= n - 300:
            break
        lines.append(f"{i}\t{'status' if len(lines) % 2 else 'help'}\\r")
    lines.append(f"{n - 150}\tmode allan\\r")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("mode,fs", [("raw", 100), ("binary", 500), ("both", 50)])
def test_replies_never_cost_a_sample(run, tmp_path: Path, mode: str, fs: int) -> None:
    """At the highest rate the link budget accepts for each mode, a storm
    of the longest replies loses no sample set (the budget counts them)."""
    r = run(f"replies-{mode}-{fs}")
    n = 6000 if fs <= 100 else 12000
    cli("gen", "-n", str(n), "--fs", str(fs), "--seed", str(fs + 3), "-o", str(r.rows))
    uart = tmp_path / "uart.txt"
    uart.write_text(_reply_storm(n, fs, mode))
    simulate_and_check(r, n, fs, uart_in=uart)
    log = _text_of(r.log.read_bytes())
    assert log.count(b"$ok help ") + log.count(b"$ok status ") >= (n - 400) // 120
    assert b"$error:" not in log


def test_budget_refuses_raw_where_replies_would_cost_samples(run, tmp_path: Path) -> None:
    """Raw at 200 and 250 Hz: rows fit the link (63 %, 79 %), but a help
    reply holds them back longer than the two-set ring lasts, so the mode
    is refused and nothing changes (the run stays whole and exact)."""
    r = run("raw-refused")
    n = 3000
    cli("gen", "-n", str(n), "--fs", "250", "--seed", "31", "-o", str(r.rows))
    uart = tmp_path / "uart.txt"
    uart.write_text("100\tmode raw\\r\n")
    simulate_and_check(r, n, 250, uart_in=uart)
    assert b"$error:4 mode: link too slow; lower rate*" in r.log.read_bytes()
