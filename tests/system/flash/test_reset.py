"""The reset cause the firmware reports (`reset=` of its boot line), with
optiboot and without a bootloader, for each cause the simulated board can
bring: power-on, the RESET pin (DTR, on opening the port) and the firmware's
own watchdog (the board hangs the firmware on SIGUSR1, as a stuck loop
would).  Optiboot 4.4 clears MCUSR before starting the firmware, so under it
a RESET-pin reset is honestly `unknown`; the watchdog reset must not loop."""

from __future__ import annotations

import os
import signal
import time

import pytest
from conftest import HEX, Board, boots

EXPECTED = {
    # bootloader: causes after power-on, a RESET-pin reset, a watchdog reset
    "optiboot": ("por", "unknown", "wdt"),
    "none": ("por", "ext", "wdt"),
}


@pytest.fixture(scope="module", params=sorted(EXPECTED))
def board(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory):
    b = Board(tmp_path_factory.mktemp(f"reset-{request.param}"), bootloader=request.param, isp=HEX)
    b.kind = request.param
    yield b
    b.stop()


def test_power_on(board: Board) -> None:
    assert board.wait_boots(1, 5) == [EXPECTED[board.kind][0]], board.errors()


def test_reset_pin(board: Board) -> None:
    board.wait_boots(1, 5)
    board.open()
    got = board.wait_boots(2, 5)
    board.close()
    assert got[1:] == [EXPECTED[board.kind][1]], board.errors()


def test_watchdog_once_and_no_loop(board: Board) -> None:
    before = len(board.wait_boots(2, 5))
    board.open()
    board.wait_boots(before + 1, 5)  # the reset the opening brings
    time.sleep(0.2)
    assert board.ask("status").startswith("ok status run=1")
    os.kill(board.proc.pid, signal.SIGUSR1)  # the firmware's loop hangs
    got = board.wait_boots(before + 2, 10)  # 2 s, more on a busy host
    assert got[before + 1 :] == [EXPECTED[board.kind][2]], board.errors()
    time.sleep(3.0)  # three watchdog periods more
    assert len(boots(board.output())) == before + 2, board.errors()
    board.ser.reset_input_buffer()
    assert board.ask("status").startswith("ok status run=1")
    board.close()
