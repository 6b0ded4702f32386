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
    assert b"rx=0:0:0:1" in text[first_header:first_header + 400]


def test_ctrl_c_or_esc_before_a_command_in_a_stream_mode(run, tmp_path: Path) -> None:
    """Ctrl-C (or Esc) then at once `mode allan`, in modes binary and raw:
    no false error:5, and the command runs."""
    r = run("ctrl-c-stream")
    n, fs = 6000, 100
    cli("gen", "-n", str(n), "--fs", str(fs), "--seed", "2011", "-o", str(r.rows))
    uart = tmp_path / "uart.txt"
    uart.write_text("100\tmode binary\\r\n1000\t\\x03mode allan\\r\n"
                    "2000\tmode raw\\r\n3000\t\\x1bmode allan\\r\n")
    simulate_and_check(r, n, fs, uart_in=uart)
    text = r.log.read_bytes()
    assert b"$error:" not in text
    assert text.count(b"$ok mode=allan*") == 2
    assert text.count(b"$ok mode=binary*") == 1 and text.count(b"$ok mode=raw*") == 1
