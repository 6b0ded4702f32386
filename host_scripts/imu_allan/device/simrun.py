"""Run the firmware in the simulator harness ``imu-sim`` (a thin wrapper).

The harness (built by ``make sim``) takes
    imu-sim [--adc FILE] [--fs HZ] [--uart-in FILE] [-o FILE] [--stats[=FILE]] ELF
This module only finds the binaries and passes the options through; it
builds nothing.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Optional, TextIO, Union

from ..errors import InputError

REPO = Path(__file__).resolve().parents[3]
"""The imu-allan checkout this package lives in (host_scripts/imu_allan/..)."""

DEFAULT_SIM = REPO / "build" / "host" / "imu-sim"
DEFAULT_ELF = REPO / "build" / "avr-atmega168" / "imu-allan.elf"


def find_sim() -> Path:
    """$IMU_SIM, else <repo>/build/host/imu-sim, else imu-sim on PATH."""
    env = os.environ.get("IMU_SIM")
    if env:
        if not (os.path.isfile(env) and os.access(env, os.X_OK)):
            raise InputError(f"IMU_SIM={env} is not an executable file (run 'make sim')")
        return Path(env)
    if DEFAULT_SIM.is_file() and os.access(DEFAULT_SIM, os.X_OK):
        return DEFAULT_SIM
    found = shutil.which("imu-sim")
    if found:
        return Path(found)
    raise InputError(f"simulator harness not found: {DEFAULT_SIM} (run 'make sim')")


def sim_command(
    adc: str,
    output: str,
    fs: Optional[str] = None,
    uart_in: Optional[str] = None,
    firmware: Optional[str] = None,
    stats: Union[bool, str, None] = None,
) -> list[str]:
    """The imu-sim command line (checks the inputs exist)."""
    elf = Path(firmware) if firmware else DEFAULT_ELF
    if not elf.is_file():
        hint = "" if firmware else " (run 'make' first)"
        raise InputError(f"firmware not found: {elf}{hint}")
    for what, path in (("--adc", adc), ("--uart-in", uart_in)):
        if path is not None and path != "-" and not os.path.isfile(path):
            raise InputError(f"{what}: cannot read '{path}': no such file")
    cmd = [str(find_sim()), "--adc", adc]
    if fs is not None:
        cmd += ["--fs", str(fs)]
    if uart_in is not None:
        cmd += ["--uart-in", uart_in]
    cmd += ["-o", output]
    if stats is True:
        cmd.append("--stats")
    elif stats:
        cmd.append(f"--stats={stats}")
    cmd.append(str(elf))
    return cmd


def run(
    cmd: list[str], adc: Optional[str] = None, fs: Union[str, float, None] = None, stream: Optional[TextIO] = None
) -> int:
    """Run the harness, streams passed through; its exit code (128+N on signal N).

    On a terminal (``stream``, stderr by default) a progress line shows how
    far imu-sim has read the ``adc`` rows file: simulated seconds (with ``fs``
    or the rate a ``gen`` header names), speed and time left."""
    from ..progress import Progress

    stream = stream if stream is not None else sys.stderr
    try:
        proc = subprocess.Popen(cmd)
    except OSError as exc:
        raise InputError(f"cannot run {cmd[0]}: {exc.strerror or exc}") from None
    try:
        with Progress("imu-sim:", stream=stream, delay=1.0) as bar:
            watch = _AdcWatch(proc.pid, adc, fs) if bar.enabled and adc else None
            while True:
                try:
                    rc = proc.wait(timeout=0.25)
                    break
                except subprocess.TimeoutExpired:
                    pass
                text = watch.text(time.monotonic() - bar.start) if watch else None
                if text:
                    bar.show(text)
    except KeyboardInterrupt:  # the terminal sent SIGINT to imu-sim too
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        raise
    return 128 + (-rc) if rc < 0 else rc


class _AdcWatch:
    """How far a process has read a file: its offset in /proc/PID/fdinfo
    (Linux; elsewhere nothing is shown).  The rows are counted once."""

    def __init__(self, pid: int, path: str, fs: Union[str, float, None]) -> None:
        self.pid, self.fd = pid, None
        self.real = os.path.realpath(path) if path != "-" else None
        try:
            self.size = os.path.getsize(self.real) if self.real else 0
        except OSError:
            self.size = 0
        try:
            self.fs: Optional[float] = float(fs) if fs else None
        except ValueError:  # imu-sim says what is wrong with it
            self.fs = None
        if not self.fs and self.size:
            self.fs = _header_rate(self.real)
        self.rows: Optional[int] = None
        self.head = 0  # bytes of the leading comment lines

    def position(self) -> Optional[int]:
        if self.fd is None:
            try:
                for fd in os.listdir(f"/proc/{self.pid}/fd"):
                    if os.readlink(f"/proc/{self.pid}/fd/{fd}") == self.real:
                        self.fd = fd
                        break
            except OSError:
                return None
        if self.fd is None:
            return None
        try:
            with open(f"/proc/{self.pid}/fdinfo/{self.fd}") as f:
                return int(f.readline().split()[1])  # "pos:\t<offset>"
        except (OSError, ValueError, IndexError):
            self.fd = None  # closed (imu-sim reads the file twice) or gone
            return None

    def text(self, wall: float) -> Optional[str]:
        pos = self.position() if self.size else None
        if pos is None or wall <= 0:
            return None
        if self.rows is None:
            self.rows, self.head = _count_rows(self.real)
        frac = min(max(pos - self.head, 0) / max(self.size - self.head, 1), 1.0)
        left = wall * (1 - frac) / frac if frac > 0 else float("nan")
        done = frac * self.rows
        if self.fs:
            sim, total = done / self.fs, self.rows / self.fs
            return (
                f"{sim:,.0f} of {total:,.0f} s simulated ({frac:.0%}), {sim / wall:,.1f}x real time, {left:,.0f} s left"
            )
        return f"row {done:,.0f} of {self.rows:,} ({frac:.0%}), {done / wall:,.0f} rows/s, {left:,.0f} s left"


def _count_rows(path: str) -> tuple[int, int]:
    """Lines that are not comments (each row is one line), and the bytes of
    the comment lines before the first row."""
    lines = comments = head = 0
    last = b"\n"
    with open(path, "rb") as f:
        first = f.read(1 << 16)
        while head < len(first) and first[head : head + 1] == b"#":
            head = first.find(b"\n", head) + 1 or len(first)
        f.seek(0)
        for block in iter(lambda: f.read(1 << 22), b""):
            lines += block.count(b"\n")
            comments += block.count(b"\n#") + (last == b"\n" and block[:1] == b"#")
            last = block[-1:]
    return max(lines - comments + (last != b"\n"), 1), head


def _header_rate(path: str) -> Optional[float]:
    """The rate a ``gen`` rows file names in its header ('..., 100 Hz')."""
    try:
        with open(path, "rb") as f:
            head = f.read(4096).decode("ascii", "replace")
    except OSError:
        return None
    m = re.search(r"^#.*?(\d+(?:\.\d+)?) Hz$", head, re.M)
    return float(m.group(1)) if m else None


__all__ = ["find_sim", "sim_command", "run", "DEFAULT_SIM", "DEFAULT_ELF"]
