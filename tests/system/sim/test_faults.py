"""The faults a real board meets, injected by the simulator (imu-sim's fault
options) into the real firmware ELF, at the thesis rate and the top one.
For each: the device keeps sampling and loses no sample it could have kept
(the run after the fault is exact, with no drop), runs no command other than
the one sent, says what happened (reset cause, cfg, clips, counters) and
recovers (commands after the fault work)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import cli
from faultsim import CHANNELS, SimRun, make_rows, simulate, write_rows

RATES = [100, 1500]
ROWS = {100: 1500, 1500: 6000}  # 15 s and 4 s of sampling


def exact_after(run: SimRun, rows: np.ndarray, tmp: Path, fs: int) -> dict:
    """The final report covers rows first_row.. exactly, none dropped."""
    first = run.stats["first_row"]
    tail = tmp / "tail.tsv"
    write_rows(tail, rows[first:])
    head = run.headers()[-1]
    assert int(head["n"]) == len(rows) - first and int(head["drops"]) == 0, head
    assert run.stats["device_drops"] == 0 and run.stats["extra_scans"] == 0
    log = tmp / "final.log"
    log.write_bytes(run.log)
    out = cli("check", str(log), str(tail), "--fs", str(fs)).stdout
    assert "OK" in out, out
    return head


def replies(run: SimRun) -> list[str]:
    return [b for b in run.lines() if b.startswith(("ok", "error"))]


POWER = [("--power-cut", "por"), ("--brown-out", "bor")]


@pytest.mark.parametrize("fs", RATES)
@pytest.mark.parametrize("event,cause", POWER)
def test_power_fails_in_a_save_loses_the_record_not_the_run(tmp_path: Path, fs: int, event: str, cause: str) -> None:
    """The supply fails right after `save` wrote its first EEPROM byte: the
    device boots saying so (reset=por or bor, cfg=corrupt: the half-written record
    fails its CRC, the defaults run), samples the rest of the rows exactly,
    and a `save` after it works."""
    n = ROWS[fs]
    rows = make_rows(tmp_path / "r.tsv", n, seed=fs)
    uart = (
        f"{n // 5}\tsave\\r\n{n // 2 - 50}\tstatus\\r\n{n // 2}\tsave\\r\n"
        f"{n // 2 + 20}\tload\\r\n{n // 2 + 40}\tstatus\\r\n"
    )
    run = simulate(tmp_path / "r.tsv", tmp_path, fs, event, "save", uart=uart)
    assert run.stats["fault_resets"] == 1 and run.stats["restarts"] == 1
    boots = run.boots()
    assert len(boots) == 2 and boots[1].endswith(f"reset={cause}"), boots
    head = exact_after(run, rows, tmp_path, fs)
    assert head["reset"].startswith(cause), head
    got = replies(run)
    assert got.count("ok saved") == 1 and "ok loaded" in got, got  # the second save
    after_cut, after_save = [r for r in got if r.startswith("ok status")]
    assert "cfg=corrupt" in after_cut and f"fs={fs}" in after_cut, after_cut
    assert "cfg=saved" in after_save and head["cfg"] == "saved", (after_save, head)


@pytest.mark.parametrize("fs", RATES)
@pytest.mark.parametrize("event,cause", POWER)
def test_power_fails_in_a_report_restarts_cleanly(tmp_path: Path, fs: int, event: str, cause: str) -> None:
    """The supply fails as the report's first L row goes out: the half report
    has no E line (the host never takes it for a whole one), the device boots
    with reset=por or bor, and the run after it is exact."""
    n = ROWS[fs]
    rows = make_rows(tmp_path / "r.tsv", n, seed=fs + 1)
    run = simulate(tmp_path / "r.tsv", tmp_path, fs, event, "report", uart=f"{n // 3}\treport\\r\n")
    boots = run.boots()
    assert len(boots) == 2 and boots[1].endswith(f"reset={cause}"), boots
    lines = run.lines()
    cut = [i for i, b in enumerate(lines) if b.startswith("B,")][1]
    assert any(b.startswith("H,") for b in lines[:cut])  # the report had begun
    assert not any(b.startswith(("L,", "E,")) for b in lines[:cut])
    head = exact_after(run, rows, tmp_path, fs)
    assert head["reset"].startswith(cause), head
    decoded = cli("decode", "--json", str(tmp_path / "final.log"))
    assert '"n": %d' % (n - run.stats["first_row"]) in decoded.stdout


@pytest.mark.parametrize("fs", RATES)
def test_eeprom_bit_flip_is_found_at_the_next_power_up(tmp_path: Path, fs: int) -> None:
    """Settings saved (interval 7), then one EEPROM bit flips and the power is
    cycled: the record fails its CRC, the device says cfg=corrupt and runs
    the defaults (interval 60), never the damaged values; it samples on
    exactly."""
    n = ROWS[fs]
    rows = make_rows(tmp_path / "r.tsv", n, seed=fs + 2)
    t_save = 1.0 + 0.25 * n / fs  # well after the save, before the status
    uart = f"{n // 20}\tinterval 7\\r\n{n // 20 + 5}\tsave\\r\n{3 * n // 4}\tstatus\\r\n"
    run = simulate(
        tmp_path / "r.tsv",
        tmp_path,
        fs,
        "--eeprom-flip",
        f"2:0x04@{t_save:.3f}",
        "--power-cut",
        f"{t_save + 0.5:.3f}",
        uart=uart,
    )
    assert run.stats["fault_eeprom_flipped"] == 1 and run.stats["fault_resets"] == 1
    got = replies(run)
    assert "ok saved" in got and "ok interval=7" in got, got
    head = exact_after(run, rows, tmp_path, fs)
    assert head["cfg"] == "corrupt", head
    status = [r for r in got if r.startswith("ok status")][-1]
    assert "cfg=corrupt" in status and "interval=60" in status, status


@pytest.mark.parametrize("fs", RATES)
@pytest.mark.parametrize("fault", ["gx=1023", "ay=0", "az=stuck"])
def test_adc_channel_railed_or_stuck_is_counted_and_exact(tmp_path: Path, fs: int, fault: str) -> None:
    """From row n/3 on one channel reads full scale, zero, or its last value:
    the device samples on with no drop, its results equal the reference
    over what the channel really read, and the header counts every railed
    code as a clip."""
    n = ROWS[fs]
    rows = make_rows(tmp_path / "r.tsv", n, seed=fs + 3)
    ch, value = fault.split("=")
    k = CHANNELS.index(ch)
    start = n // 3
    run = simulate(tmp_path / "r.tsv", tmp_path, fs, "--adc-fault", f"{fault}@{start}")
    seen = rows.copy()
    seen[start:, k] = rows[start - 1, k] if value == "stuck" else int(value)
    assert run.stats["fault_adc_conversions"] == n - start
    head = exact_after(run, seen, tmp_path, fs)
    clips = [int(c) for c in head["clips"].split(":")]
    expect = np.count_nonzero((seen == 0) | (seen == 1023), axis=0)
    assert clips == [min(int(c), 65535) for c in expect], (clips, expect)


def _interval_storm(n: int, count: int, seed: int) -> tuple[str, list[int]]:
    """COUNT `interval V` lines (distinct 4-digit V) pasted at once at row n/4,
    a `status` near the end."""
    rng = np.random.default_rng(seed)
    values = [int(v) for v in rng.choice(np.arange(1000, 3601), count, replace=False)]
    text = "".join(f"interval {v}\\r" for v in values)
    # the status goes well over 2 s after the storm: a line the storm left
    # open has timed out by then
    status = "".join(f"{n - k}\tstatus\\r\n" for k in (60, 40, 20))
    return f"{n // 4}\t{text}\n{status}", values


def _ran_as_sent(got: list[str], values: list[int]) -> int:
    """Every `ok interval=V` names a value sent, in the order sent."""
    ran = [int(m.group(1)) for r in got if (m := re.fullmatch(r"ok interval=(\d+)", r))]
    it = iter(values)
    assert all(v in it for v in ran), (ran, values)
    return len(ran)


@pytest.mark.parametrize("fs", RATES)
def test_paste_without_flow_control_runs_nothing_cut_short(tmp_path: Path, fs: int) -> None:
    """60 commands pasted with no flow control (the UART keeps two frames and
    one in its shift register, as the chip does): each runs as sent, or is
    refused with error:5, or lost whole; sampling goes on exactly, and a
    command after the storm is answered."""
    n = ROWS[fs]
    rows = make_rows(tmp_path / "r.tsv", n, seed=fs + 4)
    uart, values = _interval_storm(n, 60, fs)
    run = simulate(tmp_path / "r.tsv", tmp_path, fs, "--no-flow-control", uart=uart)
    got = replies(run)
    assert _ran_as_sent(got, values) >= 1
    # the chip's receiver keeps up with a paste at line rate: nothing overran
    assert run.stats["fault_overruns"] == 0, run.stats
    if _has_rx_counters(tmp_path):
        # the line discipline that refuses fragments whole and times out a
        # line left open, so the status after the storm is answered
        assert all(r.startswith(("ok interval=", "ok status", "error:5", "error:7")) for r in got[4:] if r != "ok"), (
            got
        )  # after the set-up, but 'report'
        assert [r for r in got if r.startswith("ok status")][-1].startswith("ok status run=1")
    exact_after(run, rows, tmp_path, fs)


def _has_rx_counters(tmp: Path) -> bool:
    """Does this firmware count receive faults (status key rx=)?"""
    make_rows(tmp / "probe.tsv", 300, seed=1)
    run = simulate(tmp / "probe.tsv", tmp, 100, uart="10\tstatus\\r\n", name="probe")
    return any(" rx=" in r for r in replies(run))


@pytest.mark.parametrize("fs", RATES)
def test_overruns_refuse_their_lines_and_are_counted(tmp_path: Path, fs: int) -> None:
    """Bytes lost to data overruns (DOR set) at 1 in 50: every line that lost
    one is refused with error:5, none runs cut short, status counts them."""
    if not _has_rx_counters(tmp_path):
        pytest.skip("this firmware does not read DOR yet (no rx= in status)")
    n = ROWS[fs]
    rows = make_rows(tmp_path / "r.tsv", n, seed=fs + 5)
    uart, values = _interval_storm(n, 40, fs + 1)
    run = simulate(tmp_path / "r.tsv", tmp_path, fs, "--uart-overrun", "0.02", "--fault-seed", str(fs), uart=uart)
    assert run.stats["fault_overruns_injected"] > 0
    got = replies(run)
    _ran_as_sent(got, values)
    refused = sum(r.startswith("error:5") for r in got)
    assert refused >= 1, got
    status = [r for r in got if r.startswith("ok status")][-1]
    overruns = int(re.search(r" rx=(\d+):", status).group(1))
    # each DOR the device saw is counted (one on a byte its full ring then
    # dropped may count as ring loss instead)
    assert 0 < overruns <= run.stats["fault_dor_events"], (status, run.stats)
    exact_after(run, rows, tmp_path, fs)


@pytest.mark.parametrize("fs", RATES)
def test_framing_errors_refuse_their_lines_and_are_counted(tmp_path: Path, fs: int) -> None:
    """Bytes arriving with a framing error (FE: the stop bit read as 0, a
    corrupted byte) at 1 in 50, their data bits left intact, so that a device
    blind to FE would run every line: each line that held one is refused
    with error:5 (the byte is thrown away, as an overrun's are), the others
    run as sent, one command at a time, and status counts the errors with
    the overruns (rx=)."""
    n = ROWS[fs]
    rows = make_rows(tmp_path / "r.tsv", n, seed=fs + 6)
    rng = np.random.default_rng(fs + 6)
    values = [int(v) for v in rng.choice(np.arange(1000, 3601), 30, replace=False)]
    at = [n // 10 + k * (n // 40) for k in range(len(values))]
    uart = "".join(f"{r}\tinterval {v}\\r\n" for r, v in zip(at, values)) + "".join(
        f"{n - k}\tstatus\\r\n" for k in (60, 40, 20)
    )
    run = simulate(tmp_path / "r.tsv", tmp_path, fs, "--uart-frame-error", "0.02", "--fault-seed", str(fs), uart=uart)
    fe = run.stats["fault_in_frame_errors"]
    assert fe > 0 and run.stats["fault_overruns"] == 0, run.stats
    got = replies(run)
    ran = _ran_as_sent(got, values)
    refused = sum(r.startswith("error:5") for r in got)
    answered = ran + refused + sum(r.startswith("ok status") for r in got)
    assert answered == len(values) + 3, got  # each line ran or was refused, none lost silently
    assert 1 <= refused <= fe, (refused, fe, got)
    status = [r for r in got if r.startswith("ok status")][-1]
    counted = int(re.search(r" rx=(\d+):", status).group(1))
    assert 0 < counted <= fe, (status, fe)
    exact_after(run, rows, tmp_path, fs)
