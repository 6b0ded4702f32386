"""The command line: help, one-line errors, exit codes, the sim wrapper."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from imu_allan.device import simrun

COMMANDS = ("decode", "reference", "check", "gen", "sim", "rows", "monitor", "cmd")


def test_help(run_cli) -> None:
    rc, out, _ = run_cli("--help")
    assert rc == 0 and all(c in out for c in COMMANDS) and "typical session" in out
    for c in COMMANDS:
        rc, out, _ = run_cli(c, "--help")
        assert rc == 0 and out.startswith(f"usage: imu-allan {c}")


def test_no_command_is_a_usage_error(run_cli) -> None:
    rc, out, err = run_cli()
    assert rc == 2 and "COMMAND" in err


@pytest.mark.parametrize(
    "argv",
    [
        ("decode", "/nonexistent/dev.log"),
        ("reference", "/nonexistent/rows.txt", "--fs", "100"),
        ("check", "/nonexistent/dev.log", "/nonexistent/rows.txt"),
        ("rows", "/nonexistent/dev.log", "-o", "/nonexistent/rows.txt"),
    ],
)
def test_missing_file_is_one_line(run_cli, argv) -> None:
    rc, out, err = run_cli(*argv)
    assert rc == 2 and out == ""
    assert err == f"imu-allan {argv[0]}: cannot read '{argv[1]}': No such file or directory\n"


def test_wrong_column_count_is_one_line(tmp_path: Path, run_cli) -> None:
    p = tmp_path / "rows.txt"
    p.write_text("# rows\n1\t2\t3\t4\t5\t6\t7\n1\t2\t3\t4\t5\t6\n")
    rc, out, err = run_cli("reference", p, "--fs", "100")
    assert rc == 2 and out == ""
    assert err == f"imu-allan reference: {p}: line 3: 6 columns, expected 7 (ax ay az gx gy gz temp)\n"


@pytest.mark.parametrize(
    "argv",
    [
        ("reference", "x.txt"),
        ("decode",),
        ("gen", "-n", "1"),
        ("rows", "x.log"),
        ("cmd", "--port", "/dev/null"),
        ("monitor",),
        ("cmd", "--port", "p", "--timeout", "0", "x"),
        ("reference", "x", "--fs", "-3"),
        ("decode", "x", "--json", "--csv"),
    ],
)
def test_usage_errors_are_one_line(run_cli, argv) -> None:
    rc, out, err = run_cli(*argv)
    assert rc == 2 and err.count("\n") == 1 and "--help" in err


def test_console_script_has_no_traceback(tmp_path: Path) -> None:
    exe = Path(sys.executable).with_name("imu-allan")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "imu_allan.cli"]
    p = subprocess.run(cmd + ["decode", str(tmp_path / "none.log")], capture_output=True, text=True)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "Traceback" not in p.stderr


# ---- sim: a thin wrapper, tried with a fake harness --------------------------------


@pytest.fixture
def fake_sim(tmp_path: Path, monkeypatch) -> Path:
    sim = tmp_path / "imu-sim"
    sim.write_text('#!/bin/sh\nprintf "%s\\n" "$@" > "$(dirname "$0")/args"\nexit 3\n')
    sim.chmod(0o755)
    monkeypatch.setenv("IMU_SIM", str(sim))
    return sim


def test_sim_passes_options_through(tmp_path: Path, run_cli, fake_sim: Path) -> None:
    elf, adc, uart = tmp_path / "fw.elf", tmp_path / "adc.txt", tmp_path / "cmds.txt"
    for p in (elf, adc, uart):
        p.write_text("x")
    rc, _, _ = run_cli(
        "sim", "--adc", adc, "--fs", "200", "--uart-in", uart, "--firmware", elf, "--stats", "-o", tmp_path / "dev.log"
    )
    assert rc == 3  # the harness's exit status
    args = (tmp_path / "args").read_text().splitlines()
    assert args == [
        "--adc",
        str(adc),
        "--fs",
        "200",
        "--uart-in",
        str(uart),
        "-o",
        str(tmp_path / "dev.log"),
        "--stats",
        str(elf),
    ]
    run_cli("sim", "--adc", adc, "--firmware", elf, "--stats", tmp_path / "st.json", "-o", "x.log")
    assert f"--stats={tmp_path / 'st.json'}" in (tmp_path / "args").read_text().splitlines()


def test_sim_hints(tmp_path: Path, run_cli, monkeypatch) -> None:
    adc = tmp_path / "adc.txt"
    adc.write_text("x")
    monkeypatch.setattr(simrun, "DEFAULT_ELF", tmp_path / "missing.elf")
    rc, _, err = run_cli("sim", "--adc", adc, "-o", tmp_path / "d.log")
    assert rc == 2 and err.count("\n") == 1 and "run 'make' first" in err
    elf = tmp_path / "fw.elf"
    elf.write_text("x")
    monkeypatch.delenv("IMU_SIM", raising=False)
    monkeypatch.setattr(simrun, "DEFAULT_SIM", tmp_path / "no-imu-sim")
    monkeypatch.setenv("PATH", str(tmp_path))
    rc, _, err = run_cli("sim", "--adc", adc, "--firmware", elf, "-o", tmp_path / "d.log")
    assert rc == 2 and err.count("\n") == 1 and "run 'make sim'" in err
    rc, _, err = run_cli("sim", "--adc", tmp_path / "none.txt", "--firmware", elf, "-o", "d.log")
    assert rc == 2 and "none.txt" in err


def test_default_paths_point_into_the_checkout() -> None:
    assert (simrun.REPO / "host_scripts" / "imu_allan" / "device" / "simrun.py").is_file()
    assert simrun.DEFAULT_SIM == simrun.REPO / "build" / "host" / "imu-sim"
    assert simrun.DEFAULT_ELF == simrun.REPO / "build" / "avr-atmega168" / "imu-allan.elf"
    assert os.path.basename(simrun.DEFAULT_ELF) == "imu-allan.elf"


# ---- output errors: one line, exit 2 (a full disk or a closed pipe is no crash) ---------


def _run(args: list[str], stdout: object, tmp: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    return subprocess.run(
        [sys.executable, "-m", "imu_allan.cli", *args],
        stdout=stdout,
        stderr=subprocess.PIPE,
        cwd=tmp,
        env=env,
        timeout=120,
    )


@pytest.fixture()
def small_rows(tmp_path: Path) -> Path:
    path = tmp_path / "imu.txt"
    assert _run(["gen", "-n", "3000", "-o", str(path)], subprocess.DEVNULL, tmp_path).returncode == 0
    return path


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize(
    "argv",
    [
        ["gen", "-n", "200000", "-o", "/dev/full"],
        ["rows", "{rows}", "-o", "/dev/full"],
        ["gen", "-n", "10", "-o", "{tmp}/x.txt", "--json-params", "/dev/full"],
        ["analyze", "{rows}", "--fs", "100", "--no-model", "--curves", "/dev/full"],
    ],
)
def test_a_full_disk_is_one_line(argv: list[str], small_rows: Path, tmp_path: Path) -> None:
    args = [a.format(rows=small_rows, tmp=tmp_path) for a in argv]
    proc = _run(args, subprocess.DEVNULL, tmp_path)
    err = proc.stderr.decode()
    assert proc.returncode == 2 and err.count("\n") == 1, err
    assert "cannot write '/dev/full': No space left on device" in err and "Traceback" not in err


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize(
    "argv", [["gen", "-n", "200000", "-o", "-"], ["reference", "{rows}", "--fs", "100"], ["rows", "{rows}", "-o", "-"]]
)
def test_a_full_or_closed_stdout_is_one_line(argv: list[str], small_rows: Path, tmp_path: Path) -> None:
    args = [a.format(rows=small_rows) for a in argv]
    with open("/dev/full", "wb") as full:
        proc = _run(args, full, tmp_path)
    err = proc.stderr.decode()
    assert proc.returncode == 2 and err.count("\n") == 1 and "No space left on device" in err, err
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    closed = subprocess.run(
        " ".join([sys.executable, "-m", "imu_allan.cli", *args]) + " >&-",
        shell=True,
        stderr=subprocess.PIPE,
        cwd=tmp_path,
        env=env,
        timeout=120,
    )
    err = closed.stderr.decode()
    assert closed.returncode == 2 and err.count("\n") == 1 and "cannot write stdout" in err, err


def test_rows_tells_lost_from_failed(tmp_path: Path, run_cli) -> None:
    """Rows written but some lost: 3; nothing found: 1; both documented in --help."""
    rc, out, _ = run_cli("rows", "--help")
    assert rc == 0 and "1 no rows or frames were found" in out and "3 written, but rows or frames" in out
    cap = tmp_path / "cap.log"
    rows = [b"%d\t1\t2\t3\t4\t5\t6\r\n" % i for i in range(300)]
    good = b"".join(rows)
    cap.write_bytes(b"junk\n" + good)
    rc, _, err = run_cli("rows", cap, "-o", tmp_path / "r.txt")
    assert rc == 0, err
    lost = tmp_path / "lost.log"
    lost.write_bytes(b"junk\n" + b"".join(rows[:100]) + b"1\t2\t3\n" + b"".join(rows[100:]))  # a bad row
    rc, _, err = run_cli("rows", lost, "-o", tmp_path / "r.txt")
    assert rc == 3 and "bad rows 1" in err
    (tmp_path / "none.log").write_bytes(b"nothing here\n")
    rc, _, err = run_cli("rows", tmp_path / "none.log", "-o", tmp_path / "r.txt")
    assert rc == 1 and "no raw rows or binary frames" in err


@pytest.mark.parametrize("text,want", [("250", 250), ("0250", 250), ("1000", 1000), ("50", 50)])
def test_sim_rate_is_one_of_the_device_rates(text: str, want: int) -> None:
    from imu_allan.cli.args import build_parser

    args = build_parser().parse_args(["sim", "--adc", "x.txt", "--fs", text, "-o", "y.log"])
    assert args.fs == want  # decimal, never octal


@pytest.mark.parametrize("text", ["0", "4294967396", "4294967346", "99", "1e2", "-100", "250.0", "abc"])
def test_sim_refuses_other_rates(text: str, run_cli) -> None:
    rc, out, err = run_cli("sim", "--adc", "x.txt", "--fs", text, "-o", "y.log")
    assert rc == 2 and out == "" and err.count("\n") == 1
    assert f"{text!r} is not a rate of the device (50, 100, 200, 250, 500, 1000, 1250, 1500 Hz)" in err


@pytest.mark.parametrize(
    "content,argv,message",
    [
        (b"", ("reference", "{f}", "--fs", "100"), "'{f}' holds no rows"),
        (b"# only a comment\n", ("reference", "{f}", "--fs", "100"), "'{f}' holds no rows"),
        (b"t,ax,ay,az,gx,gy,gz\n", ("analyze", "{f}"), "'{f}': line 1 is a header, and no data row follows it"),
        (
            b"-1\t2\t3\t4\t5\t6\t7\n1\t2\t3\t4\t5\t6\t7\n",
            ("analyze", "{f}", "--fs", "100"),
            "'{f}': line 1: '-1' is not a 10-bit ADC code",
        ),
    ],
)
def test_messages_name_the_real_cause(content: bytes, argv: tuple, message: str, tmp_path: Path, run_cli) -> None:
    f = tmp_path / "in.txt"
    f.write_bytes(content)
    rc, out, err = run_cli(*(a.format(f=f) for a in argv))
    assert rc == 2 and out == "" and err.count("\n") == 1 and message.format(f=f) in err, err


def test_stdin_is_named_stdin(monkeypatch, run_cli) -> None:
    import io

    data = b"1\t2\t3\t4\t5\t6\t7\n" * 10 + b"1\t2\t3\t4\t5\t6\n"
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(data)))
    rc, _, err = run_cli("analyze", "-", "--fs", "100")
    assert rc == 2 and err == "imu-allan analyze: <stdin>: line 11: 6 columns, expected 7 (ax ay az gx gy gz temp)\n"
