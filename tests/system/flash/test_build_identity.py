"""The build follows its settings: a changed MCU, F_CPU or BAUD rebuilds the
firmware (the Makefile's settings stamp), the ELF carries the settings it was
built with (section .imu_build, outside flash), and `make flash` refuses an
ELF built for another board or a .hex that is not its ELF's image, before
avrdude runs.  The identity is read here with avr-objcopy, not through the
Makefile's own check."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from conftest import BUILD, MCU, REPO

ELF = BUILD / f"avr-{MCU}" / "imu-allan.elf"


def make(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(
        ["make", "--no-print-directory", "-C", str(REPO), *args],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def identity(elf: Path) -> dict[str, str]:
    raw = subprocess.run(
        ["avr-objcopy", "-O", "binary", "--only-section=.imu_build", str(elf), "/dev/stdout"],
        capture_output=True,
        check=True,
    ).stdout
    words = raw.rstrip(b"\0").decode().split()
    assert words[0] == "imu-allan", words
    return dict(w.split("=", 1) for w in words[1:])


@pytest.fixture(scope="module")
def other_build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A build directory holding the firmware for BAUD=9600 (built after a default build)."""
    build = tmp_path_factory.mktemp("build")
    first = make("firmware", f"BUILD={build}")
    assert first.returncode == 0, first.stderr
    elf = build / f"avr-{MCU}" / "imu-allan.elf"
    assert identity(elf)["baud"] == "115200UL"
    second = make("firmware", f"BUILD={build}", "BAUD=9600")
    assert second.returncode == 0, second.stderr
    return build


def test_a_changed_baud_rebuilds_the_firmware(other_build: Path) -> None:
    elf = other_build / f"avr-{MCU}" / "imu-allan.elf"
    assert identity(elf) == {"mcu": MCU, "f_cpu": "10000000UL", "baud": "9600UL", "version": identity(ELF)["version"]}
    # the UART's divisor differs, so the flashed image does too
    assert (other_build / f"avr-{MCU}" / "imu-allan.hex").read_bytes() != ELF.with_suffix(".hex").read_bytes()


def test_the_same_settings_do_not_rebuild(other_build: Path) -> None:
    elf = other_build / f"avr-{MCU}" / "imu-allan.elf"
    before = elf.stat().st_mtime_ns
    again = make("firmware", f"BUILD={other_build}", "BAUD=9600")
    assert again.returncode == 0, again.stderr
    assert elf.stat().st_mtime_ns == before
    assert "avr-gcc" not in again.stdout


def test_flash_refuses_an_elf_built_for_another_baud(other_build: Path, tmp_path: Path) -> None:
    """The board asked for is 9600 baud; the ELF given was built for 115200."""
    marker = tmp_path / "avrdude-ran"
    out = make(
        "flash",
        f"BUILD={other_build}",
        "BAUD=9600",
        "PROGRAMMER=usbasp",
        f"FLASH_ELF={ELF}",
        f"AVRDUDE=touch {marker}; true",
    )
    assert out.returncode != 0
    assert "baud=115200UL" in out.stderr and "nothing flashed" in out.stderr
    assert not marker.exists()


def test_flash_check_refuses_another_clock_and_accepts_its_own(tmp_path: Path) -> None:
    # BUILD= a scratch directory: the check reads FLASH_ELF only, and the
    # repository's build keeps its settings stamp
    wrong = make("flash-check", f"BUILD={tmp_path}", f"FLASH_ELF={ELF}", "F_CPU=16000000")
    assert wrong.returncode != 0 and "f_cpu=16000000UL" in wrong.stderr
    right = make("flash-check", f"BUILD={tmp_path}", f"FLASH_ELF={ELF}")
    assert right.returncode == 0, right.stderr


def test_flash_check_refuses_a_hex_that_is_not_the_elfs(other_build: Path, tmp_path: Path) -> None:
    """An ELF whose .hex beside it was left by another build."""
    elf = tmp_path / "imu-allan.elf"
    shutil.copy(ELF, elf)
    shutil.copy(other_build / f"avr-{MCU}" / "imu-allan.hex", tmp_path / "imu-allan.hex")
    out = make("flash-check", f"BUILD={tmp_path}", f"FLASH_ELF={elf}")
    assert out.returncode != 0 and "is not the image of" in out.stderr
    shutil.copy(ELF.with_suffix(".hex"), tmp_path / "imu-allan.hex")
    assert make("flash-check", f"BUILD={tmp_path}", f"FLASH_ELF={elf}").returncode == 0
