"""The simulated board with a bootloader (`make sim-board`, `imu-sim --board`)
and what the flash tests need around it: an Intel hex reader, the device's
lines (framing and CRC-16/CCITT-FALSE via binascii.crc_hqx, independent of
the firmware and of the host package), a pyserial connection.

Run with `make flash-test` (BUILD=, IMU_SIM= point elsewhere)."""

from __future__ import annotations

import binascii
import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest
import serial

REPO = Path(__file__).resolve().parents[3]
BUILD = Path(os.environ.get("BUILD", REPO / "build"))
MCU = "atmega168"
FLASH_BYTES = 16384
BOOT_START = FLASH_BYTES - 512  # optiboot's boot section
HEX = BUILD / f"avr-{MCU}" / "imu-allan.hex"
SIM = Path(os.environ.get("IMU_SIM", BUILD / "host" / "imu-sim"))
BOOTLOADER = BUILD / "optiboot" / f"optiboot_{MCU}_10000000_115200.hex"

LINE = re.compile(rb"\$([\x20-\x7e]*)\*([0-9A-Fa-f]{4})\r\n")


def read_ihex(path: Path) -> dict[int, int]:
    """Address -> byte of an Intel hex file (record types 00, 01, 02, 03, 04)."""
    out: dict[int, int] = {}
    base = 0
    for n, text in enumerate(path.read_text().split(), 1):
        raw = bytes.fromhex(text[1:])
        assert text[0] == ":" and sum(raw) & 0xFF == 0, f"{path}:{n}: bad record"
        count, addr, kind, data = raw[0], int.from_bytes(raw[1:3], "big"), raw[3], raw[4:-1]
        assert len(data) == count, f"{path}:{n}: bad length"
        if kind == 0:
            for i, b in enumerate(data):
                out[base + addr + i] = b
        elif kind == 2:
            base = int.from_bytes(data, "big") << 4
        elif kind == 4:
            base = int.from_bytes(data, "big") << 16
        elif kind == 1:
            break
    return out


def image(hexes: list[dict[int, int]]) -> bytes:
    """A whole flash as the hex files would leave a blank chip."""
    flash = bytearray(b"\xff" * FLASH_BYTES)
    for h in hexes:
        for a, b in h.items():
            flash[a] = b
    return bytes(flash)


def bodies(data: bytes) -> list[str]:
    """Bodies of the well-framed lines with a right CRC, in order."""
    out = []
    for m in LINE.finditer(data):
        if binascii.crc_hqx(m.group(1), 0xFFFF) == int(m.group(2), 16):
            out.append(m.group(1).decode())
    return out


def boots(data: bytes) -> list[str]:
    """The reset= value of each boot line."""
    return [re.search(r",reset=([a-z+]+)", b).group(1) for b in bodies(data) if b.startswith("B,")]


@pytest.fixture(scope="session", autouse=True)
def built() -> None:
    for f, how in ((HEX, "make"), (SIM, "make sim"), (BOOTLOADER, "make bootloader")):
        if not f.is_file():
            pytest.fail(f"{f} is missing (run '{how}', or make flash-test)")


class Board:
    """A simulated board: flash and EEPROM in files under TMP, its port on
    TMP/tty, everything the device sends copied to TMP/device.log."""

    def __init__(
        self, tmp: Path, bootloader: str = "optiboot", isp: Path | None = None, via_make: bool = False
    ) -> None:
        self.tmp = tmp
        self.prefix = tmp / "board"
        self.link = tmp / "tty"
        self.log = tmp / "device.log"
        self.err = tmp / "board.err"
        self.ser: serial.Serial | None = None
        if via_make:  # exactly what a user runs
            cmd = [
                "make",
                "-s",
                "--no-print-directory",
                "-C",
                str(REPO),
                "sim-board",
                f"BUILD={BUILD}",
                f"SIM_BOARD={self.prefix}",
                f"SIM_BOARD_LINK={self.link}",
                f"SIM_BOARD_OPTS=--synthetic -v -o {self.log}",
                f"BOOTLOADER={bootloader}",
            ]
        else:
            boot = str(BOOTLOADER) if bootloader == "optiboot" else "none"
            cmd = [
                str(SIM),
                "--pty",
                "--board",
                str(self.prefix),
                "--bootloader",
                boot,
                "--link",
                str(self.link),
                "--synthetic",
                "-v",
                "-o",
                str(self.log),
            ]
            if isp is not None:
                cmd += ["--flash", str(isp)]
        self.proc = subprocess.Popen(
            cmd, stdout=subprocess.DEVNULL, stderr=open(self.err, "wb"), start_new_session=True
        )
        deadline = time.monotonic() + 30
        while not self.link.is_symlink():
            if self.proc.poll() is not None:
                raise AssertionError(f"the board exited {self.proc.returncode}: {self.errors()}")
            if time.monotonic() > deadline:
                raise AssertionError(f"no {self.link} after 30 s: {self.errors()}")
            time.sleep(0.02)

    def errors(self) -> str:
        """What the simulator said (-v: opens, resets, hangs), without
        simavr's timer noise."""
        text = self.err.read_text(errors="replace") if self.err.exists() else ""
        return "\n".join(line for line in text.splitlines() if "avr_timer_write_ocr" not in line)[-3000:]

    def output(self) -> bytes:
        return self.log.read_bytes() if self.log.exists() else b""

    def flash(self) -> bytes:
        return (self.prefix.parent / (self.prefix.name + ".flash")).read_bytes()

    def wait_boots(self, count: int, timeout: float) -> list[str]:
        """The reset causes of the boot lines, once there are COUNT of them."""
        deadline = time.monotonic() + timeout
        while True:
            got = boots(self.output())
            if len(got) >= count or time.monotonic() > deadline:
                return got
            time.sleep(0.05)

    def open(self) -> serial.Serial:
        self.ser = serial.Serial(str(self.link), 115200, timeout=0.1)
        return self.ser

    def close(self) -> None:
        if self.ser is not None:
            self.ser.close()
            self.ser = None

    def ask(self, command: str, timeout: float = 3.0) -> str:
        """Send a command on the open port; its reply's body."""
        assert self.ser is not None
        self.ser.write(command.encode() + b"\r")
        buf, deadline = b"", time.monotonic() + timeout
        while time.monotonic() < deadline:
            buf += self.ser.read(4096)
            replies = [b for b in bodies(buf) if b == "ok" or b.startswith(("ok ", "error"))]
            if replies:
                return replies[0]
        raise AssertionError(f"no reply to {command!r} in {timeout} s: {buf[-300:]!r}")

    def stop(self) -> None:
        self.close()
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()


def make_flash(link: Path, *extra: str, timeout: float = 60) -> subprocess.CompletedProcess:
    """`make flash PORT=...`, as a user runs it."""
    return subprocess.run(
        ["make", "--no-print-directory", "-C", str(REPO), "flash", f"BUILD={BUILD}", f"PORT={link}", *extra],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
