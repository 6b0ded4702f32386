"""`make fuses-dryrun`: the boot fuses follow BOOTLOADER, computed here from
the datasheets' tables (ATmega48/88/168 and ATmega328P, Boot Size
Configuration): BOOTSZ = 3 for the smallest boot section, one less for
each doubling; BOOTRST programmed (0) whenever there is a bootloader."""

from __future__ import annotations

import re
import subprocess

import pytest
from conftest import BUILD, REPO

SMALLEST = {"atmega168": 256, "atmega328p": 512}
FLASH = {"atmega168": 16384, "atmega328p": 32768}


def boot_bits(mcu: str, nbytes: int) -> int:
    """BOOTSZ1:0 and BOOTRST, as the fuse byte's bits 2..0."""
    if nbytes == 0:
        return 0b001  # BOOTSZ = 00 (factory), BOOTRST unprogrammed
    size, bootsz = SMALLEST[mcu], 3
    while size < nbytes:
        size, bootsz = size * 2, bootsz - 1
    assert size == nbytes and bootsz >= 0
    return bootsz << 1  # BOOTRST = 0: reset into the boot section


def fuses(mcu: str, bootloader: str) -> dict[str, int]:
    r = subprocess.run(
        [
            "make",
            "-s",
            "--no-print-directory",
            "-C",
            str(REPO),
            "fuses-dryrun",
            f"BUILD={BUILD}",
            f"MCU={mcu}",
            f"BOOTLOADER={bootloader}",
            "PROGRAMMER=usbasp",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 0, r.stderr
    return {k: int(v, 16) for k, v in re.findall(r"-U (\w)fuse:w:(0x[0-9A-F]{2}):m", r.stdout)}


@pytest.mark.parametrize(
    "mcu,bootloader,nbytes",
    [
        ("atmega168", "optiboot", 512),
        ("atmega168", "none", 0),
        ("atmega168", "256", 256),
        ("atmega168", "1024", 1024),
        ("atmega168", "2048", 2048),
        ("atmega328p", "optiboot", 512),
        ("atmega328p", "none", 0),
        ("atmega328p", "4096", 4096),
    ],
)
def test_boot_fuses_follow_the_bootloader(mcu: str, bootloader: str, nbytes: int) -> None:
    f = fuses(mcu, bootloader)
    boot_fuse = f["e"] if mcu == "atmega168" else f["h"]
    assert boot_fuse & 0b111 == boot_bits(mcu, nbytes)
    assert f["l"] == 0xFF  # crystal, no /8, unchanged
    if mcu == "atmega168":
        assert boot_fuse >> 3 == 0b11111  # unused bits read as 1
        assert f["h"] == 0xDD
    else:
        assert boot_fuse >> 3 == 0b11011 and f["e"] == 0xFD


def test_a_boot_section_the_chip_cannot_have_is_refused() -> None:
    r = subprocess.run(
        [
            "make",
            "-s",
            "--no-print-directory",
            "-C",
            str(REPO),
            "fuses-dryrun",
            f"BUILD={BUILD}",
            "MCU=atmega328p",
            "BOOTLOADER=256",
            "PROGRAMMER=usbasp",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode != 0 and "512 1024 2048 4096" in r.stderr
