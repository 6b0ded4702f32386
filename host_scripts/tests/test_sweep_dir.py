"""Where `imu-allan sweep` keeps its state and logs: -o/--dir when given;
otherwise build/imu-allan-sweep of the imu-allan checkout it runs in (with the
build's other outputs, which git ignores), and ./imu-allan-sweep elsewhere.
A sweep makes its directory before it opens the device, so a port that does
not exist shows where it went without any device."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

HOST = Path(__file__).resolve().parents[1]


def _sweep(cwd: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(HOST))
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "imu_allan.cli",
            "sweep",
            "--port",
            str(cwd / "no-such-port"),
            "--rates",
            "100",
            "--seconds",
            "1",
            *extra,
        ],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )


def _checkout(root: Path) -> Path:
    (root / "firmware").mkdir(parents=True)
    (root / "firmware" / "vocab.h").write_text("/* vocab */\n")
    (root / "host_scripts").mkdir()
    (root / "Makefile").write_text("all:\n")
    inner = root / "docs" / "notes"
    inner.mkdir(parents=True)
    return inner


def test_in_a_checkout_the_sweep_goes_under_its_build_directory(tmp_path: Path) -> None:
    inner = _checkout(tmp_path / "repo")
    out = _sweep(inner)
    assert out.returncode == 2, out.stderr
    assert (tmp_path / "repo" / "build" / "imu-allan-sweep").is_dir()
    assert not (inner / "imu-allan-sweep").exists()


def test_outside_a_checkout_it_goes_into_the_current_directory(tmp_path: Path) -> None:
    out = _sweep(tmp_path)
    assert out.returncode == 2, out.stderr
    assert (tmp_path / "imu-allan-sweep").is_dir()
    assert not (tmp_path / "build").exists()


def test_o_names_the_directory(tmp_path: Path) -> None:
    inner = _checkout(tmp_path / "repo")
    for flag, name in (("-o", "mine"), ("--dir", "theirs")):
        out = _sweep(inner, flag, name)
        assert out.returncode == 2, out.stderr
        assert (inner / name).is_dir()
    assert not (tmp_path / "repo" / "build").exists()
