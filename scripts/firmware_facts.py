#!/usr/bin/env python3
"""The facts the host shares with the firmware, read from the firmware's own
sources: the rate list, the ADC code range, the column order, the protocol's
words (modes, ranges, commands, error codes) and limits.  Their one home is
the firmware (vocab.h, vocab.c, config.h, adc.h, the command table);
`make facts` writes them into host_scripts/imu_allan/_firmware_facts.py, so
that the host package works installed on its own, and the host's tests fail
when the firmware and that file part.

    python3 scripts/firmware_facts.py [ROOT]            print the module
    python3 scripts/firmware_facts.py [ROOT] -o FILE    write it

Each fact is looked up by its C name in every firmware/*.h and *.c, so a
table that moves to another file is still found; a fact that is missing or
found twice is an error naming it.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path
from typing import Any

HOST_COLUMN_AFTER_CHANNELS = "temp"
"""The host's name for the column after the sensor channels (the header's `temp=`)."""


class FactError(Exception):
    pass


def _sources(root: Path) -> dict[str, str]:
    fw = root / "firmware"
    if not fw.is_dir():
        raise FactError(f"{root}: no firmware/ directory")
    return {p.name: p.read_text() for p in sorted(fw.glob("*.[ch]"))}


def _one(sources: dict[str, str], pattern: str, what: str) -> re.Match[str]:
    found = [(name, m) for name, text in sources.items() for m in re.finditer(pattern, text, re.M)]
    if len(found) != 1:
        where = ", ".join(name for name, _ in found) or "no file"
        raise FactError(f"{what}: expected one definition in firmware/, found {len(found)} ({where})")
    return found[0][1]


def _define_int(sources: dict[str, str], name: str) -> int:
    m = _one(sources, rf"^\s*#\s*define\s+{name}\s+\(?(\d+)[uUlL]*\)?\s*(?:/\*.*)?$", f"#define {name}")
    return int(m.group(1))


def _word_table(sources: dict[str, str], name: str) -> tuple[str, ...]:
    """A PROGMEM table of NUL-separated words, as vocab_word() walks it."""
    m = _one(
        sources,
        rf"\bconst\s+char\s+{name}\[\]\s+PROGMEM\s*=\s*((?:\s*\"(?:[^\"\\]|\\.)*\")+)\s*;",
        f"the word table {name}",
    )
    text = "".join(re.findall(r"\"((?:[^\"\\]|\\.)*)\"", m.group(1)))
    if re.search(r"\\(?!0)", text):
        raise FactError(f"the word table {name}: an escape other than \\0")
    return tuple(text.split("\\0"))


def parse(root: Path) -> dict[str, Any]:
    src = _sources(root)
    rates = _one(src, r"^\s*#\s*define\s+VOCAB_RATES\(X,\s*a\)(.*)$", "#define VOCAB_RATES")
    rates_hz = tuple(int(r) for r in re.findall(r"X\(a,\s*(\d+)\)", rates.group(1)))
    if not rates_hz or list(rates_hz) != sorted(set(rates_hz)):
        raise FactError(f"VOCAB_RATES: not an ascending list of rates: {rates.group(1).strip()}")
    letters = _word_table(src, "vocab_channels")
    if len(letters) != 1 or len(letters[0]) % 2:
        raise FactError("vocab_channels: not two letters a channel")
    channels = tuple(letters[0][i : i + 2] for i in range(0, len(letters[0]), 2))
    if len(channels) != _define_int(src, "ALLAN_CHANNELS"):
        raise FactError("vocab_channels and ALLAN_CHANNELS disagree")
    columns = _define_int(src, "ADC_COLUMNS")
    if columns != len(channels) + 1:
        raise FactError(f"ADC_COLUMNS {columns}: expected the {len(channels)} channels and the temperature")
    errors = {
        m.group(1).lower(): int(m.group(2))
        for text in src.values()
        for m in re.finditer(r"^\s*#\s*define\s+CMD_ERR_(\w+)\s+(\d+)", text, re.M)
    }
    if not errors:
        raise FactError("no #define CMD_ERR_* error codes")
    commands = _word_table(src, "cmd_words")
    table = _one(src, r"\bconst\s+uint8_t\s+cmd_arg\[\]\s+PROGMEM\s*=\s*\{([^}]*)\}", "the table cmd_arg")
    kinds = re.findall(r"\bARG_(\w+)", table.group(1))
    if len(kinds) != len(commands):
        raise FactError(f"cmd_arg has {len(kinds)} argument kinds for {len(commands)} command words")
    return {
        "PROTO_VERSION": _define_int(src, "PROTO_VERSION"),
        "RATES_HZ": rates_hz,
        "CODE_MAX": _define_int(src, "ALLAN_CODE_MAX"),
        "CHANNELS": channels,
        "COLUMNS": channels + (HOST_COLUMN_AFTER_CHANNELS,),
        "MODES": _word_table(src, "vocab_modes"),
        "RANGES_G": _word_table(src, "vocab_ranges"),
        "UNITS": _word_table(src, "vocab_units"),
        "ONOFF": _word_table(src, "vocab_onoff"),
        "CONFIG_SOURCES": _word_table(src, "vocab_sources"),
        "RESET_CAUSES": _word_table(src, "vocab_causes"),
        "COMMANDS": commands,
        "COMMAND_ARGS": {word: kind.lower() for word, kind in zip(commands, kinds)},
        "ERROR_CODES": dict(sorted(errors.items(), key=lambda kv: kv[1])),
        "INTERVAL_MAX_S": _define_int(src, "VOCAB_INTERVAL_MAX_S"),
        "COMMAND_LINE_MAX": _define_int(src, "COMMAND_LINE_MAX"),
    }


DOCS = {
    "PROTO_VERSION": "`proto=` of the boot line and every report header (vocab.h PROTO_VERSION).",
    "RATES_HZ": "Sample rates the device offers, ascending (vocab.h VOCAB_RATES).",
    "CODE_MAX": "Largest ADC code: a 10-bit converter (config.h ALLAN_CODE_MAX).",
    "CHANNELS": "Sensor channels, in the order of every row, report and table (vocab.c vocab_channels).",
    "COLUMNS": "Columns of a sample set (rows files, raw rows, binary frames): the sensors, then the\n"
    "temperature (adc.h ADC_COLUMNS of them).",
    "MODES": "Output modes, in the order of their numbers (vocab.c vocab_modes).",
    "RANGES_G": "Accelerometer ranges in g, in the order of their numbers (vocab.c vocab_ranges).",
    "UNITS": "The `units` setting's words (vocab.c vocab_units).",
    "ONOFF": "The `echo` setting's words, off and on (vocab.c vocab_onoff).",
    "CONFIG_SOURCES": "Where the settings in force came from, `cfg=` (vocab.c vocab_sources).",
    "RESET_CAUSES": "Reset causes, `reset=`, MCUSR's PORF EXTRF BORF WDRF (vocab.c vocab_causes).",
    "COMMANDS": "Command words the device accepts (the firmware's cmd_words table).",
    "COMMAND_ARGS": "The argument each command takes (the firmware's cmd_arg table): none, count, rate,\n"
    "seconds, mode, range, onoff or units.",
    "ERROR_CODES": "`error:N` codes of a reply, by cause (the firmware's CMD_ERR_*).",
    "INTERVAL_MAX_S": "Longest report interval in seconds (vocab.h VOCAB_INTERVAL_MAX_S).",
    "COMMAND_LINE_MAX": "Longest command line the device keeps, in characters (COMMAND_LINE_MAX).",
}


def _literal(name: str, value: Any) -> str:
    """``name = value`` as ruff format writes it: double quotes, and a
    collection too long for one line of 120 one item a line."""

    def one(v: Any) -> str:
        return json.dumps(v) if isinstance(v, str) else repr(v)

    if isinstance(value, dict):
        items, ends = [f"{one(k)}: {one(v)}" for k, v in value.items()], "{}"
    elif isinstance(value, tuple):
        items, ends = [one(v) for v in value], "()"
    else:
        return f"{name} = {one(value)}"
    line = f"{name} = {ends[0]}{', '.join(items)}{',' if len(items) == 1 and ends == '()' else ''}{ends[1]}"
    if len(line) <= 120:
        return line
    return "\n".join([f"{name} = {ends[0]}", *(f"    {i}," for i in items), ends[1]])


def render(facts: dict[str, Any]) -> str:
    out = [
        '"""The facts the host shares with the firmware, generated from firmware/ by',
        "`make facts` (scripts/firmware_facts.py); tests/test_firmware_facts.py fails",
        'when the firmware and this file part.  Edit the firmware, not this file."""',
        "",
    ]
    for name, value in facts.items():
        out += [_literal(name, value), f'"""{DOCS[name]}"""', ""]
    return "\n".join(out[:-1]) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="the host's copy of the firmware's facts")
    ap.add_argument(
        "root",
        nargs="?",
        default=str(Path(__file__).resolve().parents[1]),
        help="the repository (default: this script's)",
    )
    ap.add_argument("-o", "--output", metavar="FILE", help="write the module there (default: stdout)")
    args = ap.parse_args(argv)
    try:
        text = render(parse(Path(args.root)))
    except FactError as exc:
        print(f"firmware_facts: {exc}", file=sys.stderr)
        return 2
    if args.output:
        Path(args.output).write_text(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
