"""imu-sim with injected faults, run directly (the faults are harness options
that `imu-allan sim` does not pass on), and the device lines of its log.
Shared by test_faults.py and the link soak (soak.py)."""

from __future__ import annotations

import json
import os
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from imu_allan.device.framing import crc16

REPO = Path(__file__).resolve().parents[3]
BUILD = Path(os.environ.get("BUILD", REPO / "build"))
ELF = BUILD / "avr-atmega168" / "imu-allan.elf"
SIM = BUILD / "host" / "imu-sim"
CHANNELS = ["ax", "ay", "az", "gx", "gy", "gz", "temp"]

_LINE = re.compile(rb"\$([^$\r\n]*)\*([0-9A-F]{4})\r")


@dataclass
class SimRun:
    log: bytes
    stats: dict
    stderr: str
    returncode: int

    def lines(self) -> list[str]:
        """The device's lines whose CRC holds, in order (a line the link
        damaged is dropped, as the host tools drop it)."""
        out = []
        for m in _LINE.finditer(self.log):
            body = m.group(1)
            if crc16(body) == int(m.group(2), 16):
                out.append(body.decode("ascii", "replace"))
        return out

    def headers(self) -> list[dict]:
        return [header_fields(b) for b in self.lines() if b.startswith("H,")]

    def boots(self) -> list[str]:
        return [b for b in self.lines() if b.startswith("B,")]


def header_fields(body: str) -> dict:
    return dict(kv.split("=", 1) for kv in body.split(",") if "=" in kv)


def simulate(
    rows: Path, tmp: Path, fs: int, *options: str, uart: str | None = None, name: str = "run", check: bool = True
) -> SimRun:
    """One batch run of the firmware ELF on ROWS at FS with OPTIONS; UART
    is --uart-in text ('<row>\\t<text>' lines)."""
    log, stats = tmp / f"{name}.log", tmp / f"{name}.json"
    args = [str(SIM), "--adc", str(rows), "--fs", str(fs), "-o", str(log), "--stats-json", str(stats), *options]
    if uart is not None:
        (tmp / f"{name}.uart").write_text(uart)
        args += ["--uart-in", str(tmp / f"{name}.uart")]
    proc = subprocess.run([*args, str(ELF)], capture_output=True, text=True, errors="replace")
    if check and proc.returncode != 0:
        raise AssertionError(f"imu-sim exited {proc.returncode}: {proc.stderr}")
    st = json.loads(stats.read_text()) if stats.exists() else {}
    return SimRun(log.read_bytes() if log.exists() else b"", st, proc.stderr, proc.returncode)


def make_rows(path: Path, n: int, seed: int) -> np.ndarray:
    """Thesis-like noise codes (seeded), written as a rows file."""
    rng = np.random.default_rng(seed)
    offset = np.array([498, 494, 791, 520, 497, 498, 63])
    sigma = np.array([2.0, 2.5, 1.7, 0.9, 0.67, 0.57, 0.5])
    rows = np.clip(np.rint(offset + sigma * rng.standard_normal((n, 7))), 0, 1023).astype(int)
    write_rows(path, rows)
    return rows


def write_rows(path: Path, rows: np.ndarray) -> None:
    np.savetxt(path, rows, fmt="%d", delimiter="\t")
