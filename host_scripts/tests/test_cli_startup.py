"""`imu-allan --help` and the serial commands start without the numerical
stack: building the parser (every subcommand's --help text included) imports
no numpy, scipy, matplotlib or pyserial.  Checked in a fresh interpreter
through sys.modules, not by timing (timing lives in `make bench`)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import report_lines, thesis_like

HOST = Path(__file__).resolve().parents[1]
HEAVY = ("numpy", "scipy", "matplotlib", "serial")


def _loaded_after(code: str) -> dict:
    probe = (
        "import json, sys\n" + code + "\n"
        f"heavy = sorted(m for m in sys.modules if m.split('.')[0] in {HEAVY!r})\n"
        "print(json.dumps({'heavy': heavy, 'ours': sorted(m for m in sys.modules "
        "if m.startswith('imu_allan'))}))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", probe],
        cwd=HOST,
        capture_output=True,
        text=True,
        check=True,
        env={"PYTHONPATH": str(HOST), "PATH": "/usr/bin:/bin"},
    )
    return json.loads(out.stdout.splitlines()[-1])


def test_building_the_parser_imports_no_numerical_stack() -> None:
    got = _loaded_after("from imu_allan.cli.main import build_parser\nbuild_parser()")
    assert got["heavy"] == []
    assert "imu_allan.cli.args" in got["ours"]  # the probe really built it


@pytest.mark.parametrize(
    "words",
    [["--help"], ["gen", "--help"], ["analyze", "--help"], ["dynamic", "--help"], ["monitor", "--help"], ["--version"]],
)
def test_help_texts_import_no_numerical_stack(words: list[str]) -> None:
    code = (
        "from imu_allan.cli.main import main\n"
        f"try:\n    main({words!r})\nexcept SystemExit as e:\n    assert e.code == 0, e.code"
    )
    assert _loaded_after(code)["heavy"] == []


def test_the_package_loads_its_api_on_first_use() -> None:
    got = _loaded_after("import imu_allan\nassert imu_allan.__version__")
    assert got["heavy"] == []
    got = _loaded_after("import imu_allan\nimu_allan.oadev")
    assert "numpy" in got["heavy"]  # the probe sees an import when there is one


@pytest.mark.parametrize("json_out", [False, True], ids=["text", "json"])
def test_decode_imports_no_scipy(tmp_path: Path, json_out: bool) -> None:
    """decode reads a device log and prints it: numpy, never scipy (whose
    import alone costs more than the decoding)."""
    log = tmp_path / "dev.log"
    log.write_bytes(b"".join(report_lines(thesis_like(600, 3), levels=8)))
    argv = ["decode", *(["--json"] if json_out else []), str(log)]
    got = _loaded_after(f"from imu_allan.cli.main import main\nassert main({argv!r}) == 0")
    roots = {m.split(".")[0] for m in got["heavy"]}
    assert "numpy" in roots and "scipy" not in roots, got["heavy"]
    assert "imu_allan.device.records" in got["ours"]  # the probe really decoded
