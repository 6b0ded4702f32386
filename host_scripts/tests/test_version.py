"""One version across firmware and host: the repository's VERSION file is the
home; the Makefile passes it to the firmware (-DFW_VERSION) and `make version`
writes the host package's copy, which `pip install` reads (pyproject's dynamic
version).  These tests fail when the copies part."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

HOST = Path(__file__).resolve().parents[1]
ROOT = HOST.parent


def _version_file() -> str:
    path = ROOT / "VERSION"
    if not path.is_file():
        pytest.skip("not in the repository (host_scripts installed on its own): no VERSION file")
    return path.read_text().strip()


def test_the_host_package_says_the_repository_version() -> None:
    import imu_allan

    version = _version_file()
    assert re.fullmatch(r"\d+\.\d+\.\d+", version), version
    assert imu_allan.__version__ == version


def test_the_command_line_says_it() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "imu_allan.cli", "--version"], cwd=HOST, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == f"imu-allan {_version_file()}"


def test_pip_metadata_of_host_scripts_alone_says_it(tmp_path: Path) -> None:
    """host_scripts copied away from the repository (as pip builds it) still
    gets its version: pyproject.toml read and expanded by setuptools."""
    import shutil

    src = tmp_path / "host_scripts"
    shutil.copytree(HOST, src, ignore=shutil.ignore_patterns("*.egg-info", "__pycache__", "build"))
    code = (
        "from setuptools.config.pyprojecttoml import read_configuration; "
        "print(read_configuration('pyproject.toml', expand=True)['project']['version'])"
    )
    out = subprocess.run([sys.executable, "-W", "ignore", "-c", code], cwd=src, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == _version_file()


def test_the_makefile_gives_it_to_the_firmware() -> None:
    make = (ROOT / "Makefile").read_text()
    assert re.search(r"^VERSION := \$\(shell cat VERSION\)$", make, re.M)
    assert "-DFW_VERSION='\"$(VERSION)\"'" in make
    config = (ROOT / "firmware" / "config.h").read_text()
    assert not re.search(r'#\s*define FW_VERSION "\d', config), "a version number in config.h"


def test_the_firmware_says_it_in_its_boot_line_and_headers(tmp_path: Path) -> None:
    """The built firmware, run in imu-sim, says fw=<VERSION> in its boot line and
    every report header: the device, `imu-allan --version` and the package agree."""
    import os

    build = Path(os.environ.get("BUILD", ROOT / "build"))
    elf, sim = build / "avr-atmega168" / "imu-allan.elf", build / "host" / "imu-sim"
    if not (elf.is_file() and sim.is_file()):
        pytest.skip(f"{elf.name} or imu-sim not built (run 'make firmware sim')")
    version = _version_file()
    rows = tmp_path / "adc.tsv"
    rows.write_text("".join(f"{500 + i % 3}\t500\t500\t500\t500\t500\t300\n" for i in range(256)))
    log = tmp_path / "device.log"
    run = subprocess.run(
        [str(sim), "--adc", str(rows), "-o", str(log), str(elf)], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr[-2000:]
    said = re.findall(rb"^\$([BH]),.*?\bfw=([^,*]+)", log.read_bytes(), re.M)
    assert {kind for kind, _ in said} == {b"B", b"H"}, said
    assert {fw.decode() for _, fw in said} == {version}
    import imu_allan

    assert imu_allan.__version__ == version


def test_the_changelog_has_the_version() -> None:
    """A version is released with its CHANGELOG.md entry (Keep a Changelog)."""
    log = ROOT / "CHANGELOG.md"
    assert log.is_file(), "CHANGELOG.md is missing"
    heads = re.findall(r"^## \[([^\]]+)\]", log.read_text(), re.M)
    assert heads and heads[0] in ("Unreleased", _version_file()), heads[:2]
    assert _version_file() in heads, f"VERSION {_version_file()} has no '## [{_version_file()}]' entry"
