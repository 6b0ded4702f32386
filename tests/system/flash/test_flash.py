"""`make flash PORT=...` with the real avrdude against the real optiboot on the
simulated board (`make sim-board`): written and verified, the firmware boots
and answers, a second flash over the running firmware, read-back equal to the
hex, settings kept, an interrupted upload recovered by the next one.  The
tests run in order on one board, as a board owner's session would."""

from __future__ import annotations

import os
import random
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest
from conftest import BOOT_START, BOOTLOADER, BUILD, FLASH_BYTES, HEX, REPO, Board, boots, image, make_flash, read_ihex

PAGE = 128


@pytest.fixture(scope="module")
def board(tmp_path_factory: pytest.TempPathFactory):
    b = Board(tmp_path_factory.mktemp("board"), via_make=True)
    yield b
    b.stop()


@pytest.fixture(scope="module")
def app() -> dict[int, int]:
    return read_ihex(HEX)


def verified(result: subprocess.CompletedProcess, nbytes: int, board: Board | None = None) -> None:
    out = result.stdout + result.stderr
    assert result.returncode == 0, out[-2000:] + ("\n-- the board:\n" + board.errors() if board else "")
    assert f"{nbytes} bytes of flash written" in out, out[-2000:]
    assert f"{nbytes} bytes of flash verified" in out, out[-2000:]


def test_blank_board_runs_only_the_bootloader(board: Board) -> None:
    flash = board.flash()
    boot = read_ihex(BOOTLOADER)
    assert flash == image([boot])
    assert min(boot) == BOOT_START and max(boot) < FLASH_BYTES
    time.sleep(0.5)
    assert boots(board.output()) == []  # nothing to run yet


def test_make_flash_writes_and_verifies(board: Board, app: dict[int, int]) -> None:
    assert sorted(app) == list(range(len(app)))  # one block from 0
    verified(make_flash(board.link), len(app), board)
    # the first start of a firmware just written through the bootloader
    assert board.wait_boots(1, 5) == ["unknown"]


def test_opening_the_port_resets_and_the_firmware_answers(board: Board) -> None:
    before = len(boots(board.output()))
    ser = board.open()
    t0 = time.monotonic()
    assert board.wait_boots(before + 1, 5)[before:] == ["unknown"]  # DTR: a warm reset
    # optiboot waits about a second for avrdude, then its watchdog starts the firmware
    assert 0.8 < time.monotonic() - t0 < 3.0
    time.sleep(0.1)
    ser.reset_input_buffer()
    status = board.ask("status")
    assert re.fullmatch(
        r"ok status run=1 mode=allan range=1\.5 units=\w+ cfg=\w+ fs=100 interval=60 link=\d+ rx=\d+:\d+:\d+:\d+",
        status,
    ), status
    assert board.ask("rate 50") in ("ok rate=50", "ok reset rate=50")
    assert board.ask("save", timeout=5) == "ok saved"
    board.close()


def test_second_flash_over_the_running_firmware_keeps_the_settings(board: Board, app: dict[int, int]) -> None:
    before = len(boots(board.output()))
    verified(make_flash(board.link), len(app), board)
    assert board.wait_boots(before + 1, 5)[before:] == ["unknown"]
    board.open()
    board.wait_boots(before + 2, 5)
    time.sleep(0.1)
    status = board.ask("status")
    assert " fs=50 " in status, status  # the EEPROM survived the re-flash
    board.close()


def test_read_back_equals_the_hex(board: Board, app: dict[int, int], tmp_path: Path) -> None:
    back = tmp_path / "back.hex"
    r = subprocess.run(
        ["avrdude", "-p", "m168", "-c", "arduino", "-P", str(board.link), "-U", f"flash:r:{back}:i"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    whole = image([app, read_ihex(BOOTLOADER)])
    assert image([read_ihex(back)]) == whole  # what avrdude reads ...
    assert board.flash() == whole  # ... is what the chip's flash holds


def test_interrupted_upload_is_recovered_by_the_next(board: Board, app: dict[int, int], tmp_path: Path) -> None:
    # another firmware of the same size: its first pages are there once
    # avrdude is killed, the old firmware's last ones still are
    rng = random.Random(13)
    other = bytes(rng.randrange(256) for _ in range(len(app)))
    other_hex = tmp_path / "other.hex"
    other_hex.write_text(to_ihex(other))
    proc = subprocess.Popen(
        [
            "make",
            "--no-print-directory",
            "-C",
            str(REPO),
            "flash",
            f"BUILD={BUILD}",
            f"PORT={board.link}",
            f"FLASH_HEX={other_hex}",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.monotonic() + 30
    while pages_equal(board.flash(), other) < 16:
        assert proc.poll() is None and time.monotonic() < deadline, "the upload ended early"
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    time.sleep(0.2)
    flash = board.flash()
    npages = (len(app) + PAGE - 1) // PAGE
    written = pages_equal(flash, other)
    assert 16 <= written < npages - 8, written  # interrupted halfway
    assert flash[(npages - 2) * PAGE : (npages - 1) * PAGE] == bytes(
        app.get(a, 0xFF) for a in range((npages - 2) * PAGE, (npages - 1) * PAGE)
    )
    time.sleep(1.5)  # optiboot gives up, the half-written firmware runs astray
    before = len(boots(board.output()))
    verified(make_flash(board.link), len(app), board)
    assert board.wait_boots(before + 1, 5)[before:][-1] == "unknown"
    assert board.flash() == image([app, read_ihex(BOOTLOADER)])
    board.open()
    board.wait_boots(before + 2, 5)
    time.sleep(0.1)
    assert board.ask("status").startswith("ok status run=1")
    board.close()


def test_bootloader_hex_is_built_for_the_board() -> None:
    boot = read_ihex(BOOTLOADER)
    assert len(boot) <= 512 and min(boot) == BOOT_START
    # optiboot's version word at the end of flash: 4.4
    assert (boot[FLASH_BYTES - 1], boot[FLASH_BYTES - 2]) == (4, 4)


def test_build_refuses_a_firmware_over_the_boot_section(tmp_path: Path, app: dict[int, int]) -> None:
    copy = tmp_path / "fw.hex"
    copy.write_bytes(HEX.read_bytes())
    ok = subprocess.run(
        ["make", "--no-print-directory", "-C", str(REPO), "flash-room", f"BUILD={BUILD}", f"HEX={copy}"],
        capture_output=True,
        text=True,
    )
    assert ok.returncode == 0, ok.stderr
    assert (
        f"flash: {len(app)} of {FLASH_BYTES - 512} bytes (BOOTLOADER=optiboot), "
        f"{FLASH_BYTES - 512 - len(app)} left" in ok.stdout
    )
    small = len(app) - 1  # a boot section that leaves one byte too few
    bad = subprocess.run(
        [
            "make",
            "--no-print-directory",
            "-C",
            str(REPO),
            "flash-room",
            f"BUILD={BUILD}",
            f"HEX={copy}",
            f"APP_MAX_BYTES={small}",
        ],
        capture_output=True,
        text=True,
    )
    assert bad.returncode != 0
    assert "1 more than" in bad.stderr and "would overwrite the bootloader" in bad.stderr
    assert not copy.exists()  # nothing left to flash


def pages_equal(flash: bytes, other: bytes) -> int:
    """Leading whole pages of OTHER that FLASH holds."""
    n = 0
    while (n + 1) * PAGE <= len(other) and flash[n * PAGE : (n + 1) * PAGE] == other[n * PAGE : (n + 1) * PAGE]:
        n += 1
    return n


def to_ihex(data: bytes) -> str:
    lines = []
    for a in range(0, len(data), 16):
        chunk = data[a : a + 16]
        rec = bytes([len(chunk), a >> 8, a & 0xFF, 0]) + chunk
        lines.append(":" + (rec + bytes([-sum(rec) & 0xFF])).hex().upper())
    lines.append(":00000001FF")
    return "\n".join(lines) + "\n"
