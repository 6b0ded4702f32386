"""Run the firmware in the simulator harness ``imu-sim`` (a thin wrapper).

The harness (built by ``make sim``) takes
    imu-sim [--adc FILE] [--fs HZ] [--uart-in FILE] [-o FILE] [--stats[=FILE]] ELF
This module only finds the binaries and passes the options through; it
builds nothing.
"""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path
from typing import Optional, Union

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


def sim_command(adc: str, output: str, fs: Optional[str] = None, uart_in: Optional[str] = None,
                firmware: Optional[str] = None, stats: Union[bool, str, None] = None) -> list[str]:
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


def run(cmd: list[str]) -> int:
    """Run the harness, streams passed through; its exit code (128+N on signal N)."""
    try:
        rc = subprocess.run(cmd).returncode
    except OSError as exc:
        raise InputError(f"cannot run {cmd[0]}: {exc.strerror or exc}") from None
    return 128 + (-rc) if rc < 0 else rc


__all__ = ["find_sim", "sim_command", "run", "DEFAULT_SIM", "DEFAULT_ELF"]
