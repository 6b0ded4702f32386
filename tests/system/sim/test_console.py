"""The console's line discipline on the real firmware in simavr: a stray
byte on the link delays no report and times out alone; Ctrl-C or Esc before
a command in a stream mode costs the command nothing.  Every run's results
stay exact with no sample dropped (simulate_and_check)."""

from __future__ import annotations

from pathlib import Path

from conftest import cli
from test_scenarios import simulate_and_check


def test_stray_byte_without_end_delays_no_report(run, tmp_path: Path) -> None:
    """One `x` and nothing more at t = 10 s, the default 60 s interval: the
    reports at 60 s and 120 s come (the echo line is ended before each), and
    the open line is refused alone 2 s after the `x`, with error:7."""
    r = run("stray-byte")
    n, fs = 12500, 100
    cli("gen", "-n", str(n), "--fs", str(fs), "--seed", "2010", "-o", str(r.rows))
    uart = tmp_path / "uart.txt"
    uart.write_text(f"{10 * fs}\tx\n")
    simulate_and_check(r, n, fs, uart_in=uart)
    text = r.log.read_bytes()
    assert text.count(b"$E,") >= 3, text[-600:]  # 60 s, 120 s, and the harness's at the end
    assert text.count(b"$error:7 x: timed out; resend*") == 1
    assert text.count(b"$error:") == 1
    first_header = text.index(b"$H,")
    assert text.index(b"> x\r\n") < text.index(b"$error:7") < first_header  # 12 s: before the 60 s report
    assert b"rx=0:0:0:1" in text[first_header : first_header + 400]


def test_ctrl_c_or_esc_before_a_command_in_a_stream_mode(run, tmp_path: Path) -> None:
    """Ctrl-C (or Esc) then at once `mode allan`, in modes binary and raw:
    no false error:5, and the command runs."""
    r = run("ctrl-c-stream")
    n, fs = 6000, 100
    cli("gen", "-n", str(n), "--fs", str(fs), "--seed", "2011", "-o", str(r.rows))
    uart = tmp_path / "uart.txt"
    uart.write_text("100\tmode binary\\r\n1000\t\\x03mode allan\\r\n2000\tmode raw\\r\n3000\t\\x1bmode allan\\r\n")
    simulate_and_check(r, n, fs, uart_in=uart)
    text = r.log.read_bytes()
    assert b"$error:" not in text
    assert text.count(b"$ok mode=allan*") == 2
    assert text.count(b"$ok mode=binary*") == 1 and text.count(b"$ok mode=raw*") == 1


def _checked(text: str, flip: int | None = None) -> str:
    """``text*XXXX`` as the host tools send it (framing.crc16, the lines'
    CRC); ``flip``: the index of a byte of the whole line whose bit 0 the
    link flipped."""
    from imu_allan.device.framing import crc16

    line = f"{text}*{crc16(text.encode()):04X}"
    if flip is not None:
        line = line[:flip] + chr(ord(line[flip]) ^ 1) + line[flip + 1 :]
    return line


def test_a_command_with_its_check_runs_and_a_changed_one_is_refused(run, tmp_path: Path) -> None:
    """On the real firmware: `interval 36*XXXX` runs; the same line with a
    bit flipped in its text (`interval 37`) or in its check is refused with
    error:5 and runs nothing; one typed without a check runs."""
    r = run("command-check")
    n, fs = 3000, 100
    cli("gen", "-n", str(n), "--fs", str(fs), "--seed", "2012", "-o", str(r.rows))
    uart = tmp_path / "uart.txt"
    uart.write_text(
        f"100\t{_checked('interval 36')}\\r\n"
        f"600\t{_checked('interval 36', flip=10)}\\r\n"
        f"1100\t{_checked('interval 18', flip=13)}\\r\n"
        f"1600\tinterval 40\\r\n"
        f"2100\t{_checked('status')}\\r\n"
    )
    simulate_and_check(r, n, fs, uart_in=uart)
    text = r.log.read_bytes()
    assert text.count(b"$ok interval=36*") == 1 and b"interval=37" not in text and b"interval=18" not in text
    assert text.count(b"$error:5 ") == 2 and text.count(b"$error:") == 2
    assert text.count(b"$ok interval=40*") == 1
    status = text[text.index(b"$ok status") :]
    assert b" interval=40 " in status[:200] and b"rx=0:0:2:0" in status[:200]
    assert b"> interval 36\r\n" in text and b"> status\r\n" in text  # the check is not echoed
