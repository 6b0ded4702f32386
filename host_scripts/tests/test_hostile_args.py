"""Every subcommand over a table of hostile values: huge, tiny, NaN, inf,
negative, zero, empty, duplicate, lists of nothing, constant channels, empty
files, binary garbage, directories, missing files, unwritable outputs.  None
may end in a traceback; a refusal is one line on stderr with exit 2 (usage,
input or output error), or the command's documented 1 (nothing found).

Run in-process through ``cli.main`` (fast), a few as real subprocesses."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import report_lines, thesis_like, write_rows

NUMBERS = (
    "1e308",
    "1e-300",
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "",
    "1e999",
    "abc",
    "99999999999999999999999",
    "0x10",
    "1,2",
)
"""Values tried where a number goes."""
BAD_NUMBERS = ("nan", "inf", "-inf", "-1", "", "1e999", "abc", "0x10", "1,2")
"""Of those, the ones no numeric option may take."""


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    d = tmp_path_factory.mktemp("hostile")
    rows = thesis_like(3000, 21)
    const = np.full_like(rows, 512)
    stuck = rows.copy()
    stuck[:, 3] = 700
    f = {
        "rows": write_rows(d / "rows.txt", rows),
        "const": write_rows(d / "const.txt", const),
        "stuck": write_rows(d / "stuck.txt", stuck),
        "dir": d / "adir",
        "missing": d / "none.txt",
        "empty": d / "empty.txt",
        "garbage": d / "garbage.bin",
        "nul": d / "nul.bin",
        "longline": d / "long.txt",
        "log": d / "dev.log",
        "cr_rows": d / "cr.txt",
        "dollars": d / "dollars.log",
        "json": d / "model.json",
    }
    f["dir"].mkdir()
    f["empty"].write_bytes(b"")
    f["garbage"].write_bytes(np.random.default_rng(5).integers(0, 256, 65536, dtype=np.uint8).tobytes())
    f["nul"].write_bytes(b"\x00" * 4096)
    f["longline"].write_bytes(b"ax" * 200_000)
    f["log"].write_bytes(b"".join(report_lines(rows[:600], 6)))
    f["cr_rows"].write_bytes(f["rows"].read_bytes().replace(b"\n", b"\r"))
    f["dollars"].write_bytes(b"$" * 300_000)
    f["json"].write_text('{"channels": 1e999}')
    out = {k: str(v) for k, v in f.items()}
    out["outdir"] = str(d)
    return out


def _unwritable(tmp: Path) -> str | None:
    """A path no write can go to: a read-only directory (not for root, who
    writes anywhere), else a sysfs file that refuses writes."""
    if os.geteuid() != 0:
        ro = tmp / "ro"
        ro.mkdir(exist_ok=True)
        ro.chmod(0o500)
        return str(ro / "out.txt")
    for p in ("/sys/kernel/notes", "/proc/self/stat"):
        try:
            with open(p, "wb") as f:
                f.write(b"x")
        except OSError:
            return p
    return None


def _cases() -> list[tuple[str, ...]]:
    """(expectation, *argv): 'refused' must exit 2 (or 1 for decode/check/rows
    with nothing found) with one line; 'any' must only not trace back."""
    c: list[tuple[str, ...]] = []
    for v in NUMBERS:
        want = "refused" if v in BAD_NUMBERS else "any"
        fs_want = "refused" if v in BAD_NUMBERS or v in ("1e308", "1e-300", "0", "99999999999999999999999") else "any"
        c += [
            (fs_want, "reference", "{rows}", "--fs", v),
            (fs_want, "analyze", "{rows}", "--fs", v, "--no-model"),
            (fs_want, "thermal", "{rows}", "--fs", v),
            (fs_want, "check", "{log}", "{rows}", "--fs", v),
            (fs_want, "gen", "-n", "10", "--fs", v, "-o", "{outdir}/g.txt"),
            (
                "refused" if v in BAD_NUMBERS or v in ("0", "99999999999999999999999", "1e308") else "any",
                "reference",
                "{rows}",
                "--fs",
                "100",
                "--levels",
                v,
            ),
            (want, "analyze", "{rows}", "--fs", "100", "--no-model", "--seed", v),
            (want if v not in ("0",) else "refused", "analyze", "{rows}", "--fs", "100", "--no-model", "--memory", v),
            (
                "refused" if v not in ("99999999999999999999999",) else "any",
                "analyze",
                "{rows}",
                "--fs",
                "100",
                "--no-model",
                "--scale",
                f"gx={v}",
            ),
            ("refused", "thermal", "{rows}", "--fs", "100", "--temp-scale", f"{v},0"),
            ("refused", "sweep", "--port", "{missing}", "--rates", v, "--seconds", "1"),
            ("refused", "sweep", "--port", "{missing}", "--rates", "100", "--seconds", v),
            ("refused", "cmd", "--port", "{missing}", "--timeout", v, "status"),
            ("refused", "cmd", "--port", "{missing}", "--baud", v, "status"),
            ("refused", "monitor", "--port", "{missing}", "--baud", v),
            ("refused", "sim", "--model", "{json}", "--seconds", v, "-o", "{outdir}/s.log"),
            ("refused", "sim", "--adc", "{rows}", "--fs", v, "-o", "{outdir}/s.log"),
        ]
        if v in BAD_NUMBERS + ("1e308", "1e-300"):  # thermal takes the others: a slow whole study
            c.append(("refused", "thermal", "{rows}", "--fs", "100", "--segments", v))
        if v not in ("-1", "", "0", "1e-300"):  # offsets in degrees may be those
            c.append(("refused", "thermal", "{rows}", "--fs", "100", "--temp-scale", f"1,{v}"))
        if v in BAD_NUMBERS:
            c += [
                ("refused", "gen", "-n", v, "-o", "{outdir}/g.txt"),
                ("refused", "gen", "-n", "10", "--seed", v, "-o", "{outdir}/g.txt"),
                ("refused", "sweep", "--port", "{missing}", "--rates", "100", "--seconds", "1", "--average", v),
            ]
    for spec in (
        "gx=99999999999999999999999",
        "ax=1,ax=2",
        ",,,",
        "",
        "ax=1e-320",
        "ax=nan",
        "ax=inf",
        "ax=1e308",
        "ax=-1",
        "qq=1",
        "ax=1furlong",
        "ax",
        "=1",
        "ax=1,,",
        "gx=1e400",
    ):
        want = "any" if spec in ("ax=1,,", "gx=99999999999999999999999") else "refused"
        c.append((want, "analyze", "{rows}", "--fs", "100", "--no-model", "--scale", spec))
    c.append(("refused", "analyze", "{rows}", "--fs", "100", "--no-model", "--scale", "ax=1", "--scale", "ax=2"))
    for chans in ("gx,gx", ",,,", "", "qq", "gx,"):
        c.append(("refused", "analyze", "{rows}", "--fs", "100", "--no-model", "--channels", chans))
    for rates in ("100,100", ",,,", "77", "1e308", "100.5"):
        c.append(("refused", "sweep", "--sim", "--rates", rates, "--seconds", "1", "--dir", "{outdir}/sw"))
    for name in ("missing", "dir", "empty", "garbage", "nul", "longline", "dollars", "const", "stuck", "cr_rows"):
        data = name in ("const", "stuck", "cr_rows")  # readable rows: used, whatever they hold
        rows_like = data or name in ("empty", "dollars")  # a rows reader finds 0 rows or some
        c += [
            ("any" if name != "stuck" else "skip", "analyze", "{%s}" % name, "--fs", "100", "--no-model")
            if data
            else ("refused", "analyze", "{%s}" % name, "--fs", "100", "--no-model"),
            ("any" if data else "refused", "reference", "{%s}" % name, "--fs", "100"),
            ("refused", "decode", "{%s}" % name),
            ("refused", "check", "{%s}" % name, "{rows}"),
            ("any" if data else "refused", "rows", "{%s}" % name, "-o", "{outdir}/r.txt"),
            ("refused", "sim", "--adc", "{%s}" % name, "-o", "{outdir}/s.log")
            if not data
            else ("refused", "sim", "--adc", "{%s}" % name, "-o", "{dir}"),
            ("refused", "gen", "--model", "{%s}" % name, "-o", "{outdir}/g.txt"),
            ("any" if rows_like else "refused", "check", "{log}", "{%s}" % name),
            ("refused", "analyze", "{rows}", "--fs", "100", "--no-model", "--device", "{%s}" % name),
        ]
        if not data:  # thermal runs the whole analysis on data it takes: only the refusals here
            c.append(("refused", "thermal", "{%s}" % name, "--fs", "100"))
    c += [
        ("any", "thermal", "{stuck}", "--fs", "100", "--segments", "0", "--temp-scale", "0.5,-40"),
        ("refused", "thermal", "{rows}", "--fs", "100", "--temp-scale", "1e-300,0"),
    ]
    for out in ("{dir}", "{missing}/x/y.txt", "{unwritable}", "/dev/full"):
        c += [
            ("refused", "gen", "-n", "100", "-o", out),
            ("refused", "rows", "{log}", "-o", out),
            ("refused", "analyze", "{rows}", "--fs", "100", "--no-model", "--curves", out),
            ("refused", "analyze", "{rows}", "--fs", "100", "--no-model", "--kalibr", out),
            ("refused", "gen", "-n", "10", "-o", "{outdir}/g.txt", "--json-params", out),
        ]
        if out != "/dev/full":
            c.append(("refused", "monitor", "--port", "{missing}", "--log", out))
    for out in ("{garbage}/p", "{unwritable}/p"):
        c += [
            ("refused", "analyze", "{rows}", "--fs", "100", "--no-model", "--plot", out),
            ("refused", "sweep", "--port", "{missing}", "--rates", "100", "--seconds", "1", "--dir", out),
        ]
    c += [
        ("refused", "monitor", "--port", "{dir}"),
        ("refused", "cmd", "--port", "{garbage}", "status"),
        ("refused", "cmd", "--port", "{missing}", ""),
        ("refused", "cmd", "--port", "{missing}", "st\x01"),
        ("refused", "decode", "-", "--json", "--csv"),
        ("refused", "check", "-", "-"),
        ("refused", "analyze", "{rows}", "--fs", "100", "--range", "3"),
        ("refused", "analyze", "{rows}", "--fs", "100", "--taus", "weekly"),
        ("refused", "sweep", "--port", "{missing}", "--rates", "100", "--seconds", "1", "--terms", ",,,"),
        ("refused", "sweep", "--port", "{missing}", "--rates", "100", "--seconds", "1", "--terms", "Z"),
    ]
    return c


CASES = _cases()


def _main(capfd: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    """``cli.main(argv)`` in this process; stdout and stderr captured at the
    file descriptors, so that the simulator harness's own line is seen too."""
    from imu_allan.cli.main import main

    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse usage errors
        rc = int(exc.code or 0)
    out, err = capfd.readouterr()
    return rc, out, err


@pytest.mark.parametrize("case", CASES, ids=[" ".join(c[1:])[:60] for c in CASES])
def test_no_traceback_and_one_line_refusals(
    case: tuple[str, ...], files: dict[str, str], capfd: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    want, *argv = case
    if want == "skip":
        pytest.skip("covered by a real process below")
    unwritable = _unwritable(tmp_path)
    if any("{unwritable}" in a for a in argv) and unwritable is None:
        pytest.skip("no unwritable path on this machine")
    if "/dev/full" in argv and not os.path.exists("/dev/full"):
        pytest.skip("needs /dev/full")
    args = [a.format(**files, unwritable=unwritable) for a in argv]
    rc, out, err = _main(capfd, args)  # an exception here is the traceback a user would see
    lines = [ln for ln in err.splitlines() if ln.strip() and ": warning: " not in ln]
    if want == "refused":
        assert rc in (1, 2), (rc, err)
    if rc == 2 or (want == "refused" and rc == 1):
        assert len(lines) == 1, err
        assert lines[0].startswith("imu-"), err  # imu-allan, or the simulator harness imu-sim
        assert len(lines[0]) < 400, lines[0][:400]
    assert "Traceback" not in err


def test_the_table_covers_every_subcommand() -> None:
    from imu_allan.cli.main import COMMANDS

    covered = {c[1] for c in CASES}
    assert covered >= set(COMMANDS) | {"sweep", "thermal"}, set(COMMANDS) - covered
    assert len(CASES) >= 300


@pytest.mark.parametrize(
    "argv",
    [
        ["analyze", "{rows}", "--fs", "1e308"],
        ["thermal", "{const}", "--fs", "100"],
        ["analyze", "{rows}", "--fs", "100", "--scale", "ax=1,ax=2"],
        ["decode", "{garbage}"],
        ["thermal", "{rows}", "--fs", "1e-300"],
        ["analyze", "{longline}", "--fs", "100"],
    ],
)
def test_real_processes_show_no_traceback(argv: list[str], files: dict[str, str], tmp_path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    proc = subprocess.run(
        [sys.executable, "-m", "imu_allan.cli", *[a.format(**files) for a in argv]],
        capture_output=True,
        cwd=tmp_path,
        env=env,
        timeout=300,
    )
    err = proc.stderr.decode()
    assert "Traceback" not in err and proc.returncode in (0, 1, 2), err
    if proc.returncode:
        assert len(err.splitlines()) == 1 and len(err) < 400, err[:400]
