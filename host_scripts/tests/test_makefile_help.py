"""`make help` lists every target of the Makefile and the fragments it
includes, one line each, from the `## ` comment on the target's own rule: a
target without one is a target a newcomer cannot find."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _makefiles() -> list[Path]:
    top = ROOT / "Makefile"
    if not top.is_file():
        pytest.skip("not in the repository (host_scripts installed on its own): no Makefile")
    included = re.findall(r"^include\s+(\S+)", top.read_text(), re.M)
    return [top] + [ROOT / p for p in included]


def _phony_targets() -> set[str]:
    names: set[str] = set()
    for mk in _makefiles():
        for line in re.findall(r"^\.PHONY:(.*)$", mk.read_text(), re.M):
            names.update(w for w in line.split() if "$" not in w)
    return names


def _help_lines() -> dict[str, str]:
    if shutil.which("make") is None:
        pytest.skip("no make on this machine")
    out = subprocess.run(
        ["make", "-s", "--no-print-directory", "help"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout
    listed: dict[str, str] = {}
    for line in out.splitlines():
        if line.startswith("  "):
            m = re.match(r"  (\S+(?: \S+)*?)\s{2,}(\S.*)$", line)
            assert m, f"make help line without a name and a text: {line!r}"
            for name in m.group(1).split():
                listed[name] = m.group(2)
    return listed


def test_every_phony_target_has_a_line_in_make_help() -> None:
    listed = _help_lines()
    missing = sorted(_phony_targets() - set(listed))
    assert not missing, f"targets without a `## ` line on their rule: {missing}"


def test_make_help_names_only_targets_that_exist() -> None:
    listed = _help_lines()
    phony = _phony_targets()
    stray = sorted(n for n in listed if n not in phony and "<" not in n)
    assert not stray, f"make help lists names that are not .PHONY targets: {stray}"
    assert all(text.strip() for text in listed.values())
