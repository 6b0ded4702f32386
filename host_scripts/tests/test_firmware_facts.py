"""One home for each fact the host shares with the firmware: the rate list,
the code range, the column order, the protocol's words.  The firmware's
sources are the home; imu_allan/_firmware_facts.py is the host's copy,
written by `make facts` (scripts/firmware_facts.py).  These tests fail when
the two part, and when a host module keeps a copy of its own."""

from __future__ import annotations

import argparse
import importlib.util
import re
import shutil
from pathlib import Path
from types import ModuleType

import pytest

from imu_allan import _firmware_facts as facts
from imu_allan import channels, profiles

HOST = Path(__file__).resolve().parents[1]
ROOT = HOST.parent


def _generator() -> ModuleType:
    script = ROOT / "scripts" / "firmware_facts.py"
    if not (script.is_file() and (ROOT / "firmware").is_dir()):
        pytest.skip("not in the repository (host_scripts installed on its own): no firmware sources")
    spec = importlib.util.spec_from_file_location("firmware_facts", script)
    assert spec and spec.loader
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_host_copy_is_what_the_firmware_says() -> None:
    gen = _generator()
    fresh = gen.render(gen.parse(ROOT))
    assert (HOST / "imu_allan" / "_firmware_facts.py").read_text() == fresh, (
        "firmware/ and imu_allan/_firmware_facts.py part: run `make facts`"
    )


def test_the_firmware_values_read_independently() -> None:
    """The generator's reading checked against a plain reading of the sources."""
    _generator()
    vocab_h = (ROOT / "firmware" / "vocab.h").read_text()
    line = re.search(r"#define VOCAB_RATES\(X, a\)(.*)", vocab_h)
    assert line and facts.RATES_HZ == tuple(int(x) for x in re.findall(r"\d+", line.group(1)))
    vocab_c = (ROOT / "firmware" / "vocab.c").read_text()
    vocab_c = re.sub(r'"\s*"', "", vocab_c)
    assert f'"{"".join(facts.CHANNELS)}"' in vocab_c
    assert '"' + "\\0".join(facts.MODES) + '"' in vocab_c
    config_h = (ROOT / "firmware" / "config.h").read_text()
    assert re.search(rf"#define ALLAN_CODE_MAX {facts.CODE_MAX}u\b", config_h)
    assert facts.CODE_MAX == 2**10 - 1 and len(facts.COLUMNS) == 7
    # adjacent C string literals joined, as the compiler joins them
    sources = re.sub(r'"\s*"', "", "".join(p.read_text() for p in (ROOT / "firmware").glob("*.c")))
    assert '"' + "\\0".join(facts.COMMANDS) + '"' in sources
    assert list(facts.COMMAND_ARGS) == list(facts.COMMANDS)
    assert facts.COMMAND_ARGS["rate"] == "rate" and facts.COMMAND_ARGS["save"] == "none"


def test_cmd_help_names_every_command_of_the_firmware() -> None:
    """`imu-allan cmd --help` lists the device's commands from the firmware's table
    (it once missed `echo` and `units`, added to the firmware after it was written)."""
    from imu_allan.cliargs import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    text = sub.choices["cmd"].format_help()
    for word in facts.COMMANDS:
        assert re.search(rf"\b{word}\b", text), word
    assert "mode <" + "|".join(facts.MODES) + ">" in text
    assert "units [" + "|".join(facts.UNITS) + "]" in text


def test_a_changed_rate_list_changes_the_host_copy(tmp_path: Path) -> None:
    gen = _generator()
    shutil.copytree(ROOT / "firmware", tmp_path / "firmware")
    vocab = tmp_path / "firmware" / "vocab.h"
    vocab.write_text(vocab.read_text().replace("X(a, 1500)", "X(a, 1500) X(a, 2000)"))
    assert gen.parse(tmp_path)["RATES_HZ"][-2:] == (1500, 2000)
    assert gen.render(gen.parse(tmp_path)) != (HOST / "imu_allan" / "_firmware_facts.py").read_text()
    vocab.write_text(vocab.read_text().replace("#define VOCAB_RATES(X, a)", "#define RATES_GONE(X, a)"))
    with pytest.raises(gen.FactError, match="VOCAB_RATES"):
        gen.parse(tmp_path)


def test_the_host_modules_take_the_facts_from_the_one_copy() -> None:
    assert channels.RATES_HZ is facts.RATES_HZ
    assert channels.COLUMNS is facts.COLUMNS and channels.CHANNELS is facts.CHANNELS
    assert channels.CODE_MAX == facts.CODE_MAX == profiles.ADC_STEPS - 1
    assert profiles.RANGES == facts.RANGES_G
    assert set(profiles.ACC_SENSITIVITY_V_PER_G) == set(facts.RANGES_G)


def test_no_other_copy_of_the_rate_list_in_the_host_or_the_bench() -> None:
    """A literal list of the rates anywhere else would drift from the firmware's."""
    listed = r"\b" + r"\s*,\s*".join(str(r) for r in facts.RATES_HZ[:4]) + r"\b"
    places = list((HOST / "imu_allan").rglob("*.py")) + list((ROOT / "bench").glob("*.py"))
    copies = [
        str(p.relative_to(ROOT if ROOT in p.parents else HOST))
        for p in places
        if p.name != "_firmware_facts.py" and p.is_file() and re.search(listed, p.read_text())
    ]
    assert not copies, f"a copy of the rate list in {copies}: import it from imu_allan.channels"
