"""Helpers shared by the tests: an encoder of device logs written from
scratch (CRC from binascii, acc from plain Python ints), independent of the
package's own code."""

from __future__ import annotations

import binascii
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np
import pytest

CH = ("ax", "ay", "az", "gx", "gy", "gz")


def crc(body: bytes) -> int:
    """CRC-16/CCITT-FALSE, by binascii (crc_hqx with init 0xFFFF)."""
    return binascii.crc_hqx(body, 0xFFFF)


def line(body: str, lower: bool = False) -> bytes:
    b = body.encode("ascii")
    c = f"{crc(b):04x}" if lower else f"{crc(b):04X}"
    return b"$" + b + b"*" + c.encode() + b"\r\n"


def exact_acc(codes: Sequence[int], m: int, pairs: int) -> int:
    """Sum of squared differences of consecutive m-sums, plain Python ints."""
    s = [sum(codes[j * m : (j + 1) * m]) for j in range(pairs + 1)]
    return sum((s[j] - s[j - 1]) ** 2 for j in range(1, pairs + 1))


def header_body(seq: int, levels: int, n: int, fs: int = 100, drops: int = 0, run: int = 0, extra: str = "") -> str:
    return (
        f"H,{seq},proto=1,fw=0.1.0,mcu=atmega168,fcpu=10000000,baud=115200,fs={fs},"
        f"levels={levels},n={n},drops={drops},clips=0:1:2:3:4:5:6,temp=63.2:50:68,"
        f"run={run},reset=por+ext{extra}"
    )


def report_lines(
    rows: np.ndarray,
    levels: int,
    seq: int = 0,
    fs: int = 100,
    drops: int = 0,
    tweak: Optional[Callable[[str, int, int, int, int], tuple[int, int, int]]] = None,
    header_n: Optional[int] = None,
    extra: str = "",
) -> list[bytes]:
    """A complete report for codes ``rows`` (shape (N, 7)) as the device sends it
    at the end of a stopped run of N samples (or, with ``header_n``, while
    running: the header says n = header_n, the rows cover all N samples).
    ``tweak(ch, level, pairs, acc, flags)`` may alter a row's (pairs, acc, flags)."""
    n = len(rows)
    out = [
        line(
            header_body(
                seq,
                levels,
                n if header_n is None else header_n,
                fs,
                drops,
                run=0 if header_n is None else 1,
                extra=extra,
            )
        )
    ]
    for c, ch in enumerate(CH):
        codes = [int(v) for v in rows[:, c]]
        for k in range(levels):
            m = 1 << k
            pairs = max(n // m - 1, 0)
            acc, flags = exact_acc(codes, m, pairs), 0
            if tweak:
                pairs, acc, flags = tweak(ch, k, pairs, acc, flags)
            out.append(line(f"L,{seq},{ch},{k},{pairs},{acc:012X},{flags:02X}"))
    # the summary's title line, then its column heading (docs/protocol.md)
    out.append(line(f"S,{seq},Allan deviation (ADC counts) by tau (s); T lines: N, B in counts"))
    out.append(line(f"S,{seq},   tau_s       ax       ay       az       gx       gy       gz"))
    out.append(line(f"E,{seq},{6 * levels}"))
    return out


def write_rows(path: Path, rows: np.ndarray, comment: str = "# test rows\n") -> Path:
    with open(path, "w") as f:
        f.write(comment)
        for r in rows:
            f.write("\t".join(str(int(v)) for v in r) + "\n")
    return path


def thesis_like(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    off = np.array([498, 494, 791, 520, 497, 498, 63])
    sd = np.array([2.0, 2.5, 1.7, 0.85, 0.6, 0.5, 0.3])
    walk = np.cumsum(0.05 * rng.standard_normal((n, 7)), axis=0)
    return np.clip(np.rint(off + sd * rng.standard_normal((n, 7)) + walk), 0, 1023).astype(int)


@pytest.fixture
def run_cli(capsys: pytest.CaptureFixture[str]) -> Callable[..., tuple[int, str, str]]:
    from imu_allan.cli.main import main

    def run(*argv: str) -> tuple[int, str, str]:
        try:
            rc = main([str(a) for a in argv])
        except SystemExit as exc:  # argparse usage errors, --help
            rc = int(exc.code or 0)
        out, err = capsys.readouterr()
        return rc, out, err

    return run


# ---- raw rows and binary frames, encoded independently of imu_allan.stream ------


def raw_row(codes: Sequence[int]) -> bytes:
    """One raw row as the device sends it: 7 codes, tab-separated, CR LF."""
    return "\t".join(str(int(v)) for v in codes).encode() + b"\r\n"


def bin_frame(seq: int, codes: Sequence[int]) -> bytes:
    """One 13-byte binary frame, from the table of docs/protocol.md."""
    c = [int(v) for v in codes]
    word = 0
    for i, v in enumerate(c):
        word |= (v >> 8) << (2 * i)
    body = bytes([seq & 0xFF]) + bytes(v & 0xFF for v in c) + word.to_bytes(2, "little")
    return b"\xa5" + body + crc(body).to_bytes(2, "big")


def random_codes(n: int, seed: int) -> np.ndarray:
    """(n, 7) codes 0..1023 with the extremes and codes whose low byte is
    '$' (0x24), CR, LF or 0xA5 mixed in."""
    rng = np.random.default_rng(seed)
    out = rng.integers(0, 1024, (n, 7))
    special = np.array([0, 1023, 0x24, 0x124, 0x0D, 0x20A, 0x0A, 0xA5, 0x3A5, 9])
    mask = rng.random((n, 7)) < 0.2
    out[mask] = rng.choice(special, int(mask.sum()))
    return out
