"""The pieces every ``imu-allan`` subcommand's options are built from: the
one-line usage errors, the value checkers (a rate, a count, seconds, a channel
list ...) and the exit statuses the --help texts quote."""

from __future__ import annotations

import argparse
from typing import NoReturn

from ..channels import CHANNELS, FS_LIMITS_HZ, RATES_HZ

EXIT_LOST = 3
"""Exit status of a command that did its work but found data lost on the way."""
EPILOG_EXIT = "exit status: 0 success, 1 {one}, 2 usage, input or output error (one line on stderr)"


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit 2)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def _positive_float(text: str, unit: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (v > 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a positive number of {unit}: {text!r}")
    return v


def _fs(text: str) -> float | int:
    v = _positive_float(text, "Hz")
    lo, hi = FS_LIMITS_HZ
    if not lo <= v <= hi:
        raise argparse.ArgumentTypeError(f"{text!r} Hz is outside {lo:g} .. {hi:g} Hz")
    return int(v) if v.is_integer() else v


def _device_rate(text: str) -> int:
    """A rate the device accepts, written in decimal (``0250`` is 250, not octal)."""
    t = text.strip()
    v = int(t) if t.isdigit() and t.isascii() else None
    if v not in RATES_HZ:
        raise argparse.ArgumentTypeError(f"{text!r} is not a rate of the device ({', '.join(map(str, RATES_HZ))} Hz)")
    return v


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"must not be negative: {text}")
    return v


def _count(text: str) -> int:
    """A row count: 100000, or 1e6."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a count: {text!r}") from None
    if not (v >= 0 and v.is_integer()):
        raise argparse.ArgumentTypeError(f"must be a whole number of rows: {text!r}")
    return int(v)


def _baud(text: str) -> int:
    v = _positive_int(text)
    if v == 0:
        raise argparse.ArgumentTypeError("must be a positive number of baud")
    return v


SECONDS_MAX = 1e7
"""Longest duration an option takes (116 days): a sweep or a model run that
long already makes more rows than a disk holds."""


def _seconds(text: str) -> float:
    v = _positive_float(text, "seconds")
    if v > SECONDS_MAX:
        raise argparse.ArgumentTypeError(f"{text!r} s is more than {SECONDS_MAX:g} s")
    return v


def _levels(text: str) -> int:
    v = _positive_int(text)
    if not 1 <= v <= 32:
        raise argparse.ArgumentTypeError("must be 1..32")
    return v


def _add_format(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--json", action="store_true", help="print JSON: {header, rows, errors} (a stable interface for scripts)"
    )
    g.add_argument("--csv", action="store_true", help="print CSV, one line per row, with a header line")


def _nonnegative_seconds(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not 0 <= v < 1e9:
        raise argparse.ArgumentTypeError(f"must be 0 s or more: {text!r}")
    return v


def _channel_list(text: str) -> list[str]:
    chans = [c.strip() for c in text.split(",")]
    bad = [c for c in chans if c not in CHANNELS]
    if bad:
        what = "an empty channel name" if not bad[0] else f"unknown channel {bad[0]!r}"
        raise argparse.ArgumentTypeError(f"{what} in {text!r} (channels: {' '.join(CHANNELS)})")
    twice = [c for i, c in enumerate(chans) if c in chans[:i]]
    if twice:
        raise argparse.ArgumentTypeError(f"channel {twice[0]!r} named twice in {text!r}")
    return chans


def _megabytes(text: str) -> int:
    v = _positive_int(text)
    if v < 1:
        raise argparse.ArgumentTypeError("must be at least 1 MB")
    return v
