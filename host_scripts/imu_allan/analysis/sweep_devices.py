"""The two devices of ``imu-allan sweep`` (sweep.py): the real firmware in the
simulator fed by the sensor model (``sim_measure``), or a board on a serial port
(``port_measure``).  Each measures one rate into a device log and returns what
the sweep keeps beside the log's analysis."""

from __future__ import annotations

import os
import subprocess
import time
from typing import Any, Optional

import numpy as np

from ..channels import CHANNELS
from ..device.link import command_line
from ..errors import InputError
from ..progress import Progress
from .sweep import Measure, Sweep, rate_key


def sim_measure(sw: Sweep, firmware: Optional[str] = None, keep_rows: bool = False) -> Measure:
    """Each rate: rows from the sensor model at that rate's ADC instants, the real
    firmware in imu-sim on them (rate set as after 'rate'), its log."""
    from ..device.simrun import sim_command
    from ..noise.sensor import Board, SensorModel
    from ..sources.rows import format_rows

    cfg = sw.config
    model = SensorModel(cfg.model)  # type: ignore[arg-type]

    def measure(fs: float, log: str) -> dict[str, Any]:
        if not float(fs).is_integer():
            raise InputError(f"--rates: the device takes whole Hz, not {fs:g}")
        n = int(round(cfg.seconds * fs))
        rows = os.path.join(sw.directory, f"rate-{rate_key(fs)}.tsv")
        board = Board(model, fs, n, seed=cfg.seed * 100003 + int(fs), average=cfg.average)
        s1 = np.zeros(7)
        s2 = np.zeros(7)
        with open(rows, "wb") as f, Progress(f"{rate_key(fs)} Hz: sensor model", n, unit=" rows") as bar:
            done = 0
            for block in board.blocks():
                f.write(format_rows(block))
                b = block.astype(np.float64)
                s1 += b.sum(axis=1)
                s2 += np.square(b).sum(axis=1)
                done += block.shape[1]
                bar.update(done)
        cmd = sim_command(rows, log, fs=str(int(fs)), firmware=firmware)
        t0 = time.monotonic()
        with Progress(f"{rate_key(fs)} Hz: firmware in imu-sim", None) as bar:
            proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            while proc.poll() is None:
                bar.update(time.monotonic() - t0)
                time.sleep(0.2)
            err = proc.stderr.read() if proc.stderr else ""
        if proc.returncode != 0:
            raise InputError(
                f"imu-sim failed at {fs:g} Hz (exit {proc.returncode}): "
                f"{err.strip().splitlines()[-1] if err.strip() else 'no message'}"
            )
        if not keep_rows:
            os.unlink(rows)
        mean = s1 / n
        std = np.sqrt(np.maximum(s2 / n - mean * mean, 0.0))
        from ..noise.sensor import SENSORS, aliased_n

        law = {
            ch: aliased_n(model.channel(ch)["N"], model.channel(ch)["bandwidth_hz"], fs, average=cfg.average)
            for ch in SENSORS
        }
        return {
            "sim": {
                "series_std": dict(zip(CHANNELS, std[:6].tolist())),
                "N_law": law,
                "seconds_wall": time.monotonic() - t0,
            }
        }

    return measure


def port_measure(sw: Sweep, port: str, baud: int) -> Measure:
    """Each rate on a real board: rate, reset, wait, report; every byte logged."""
    from ..device.link import open_port

    cfg = sw.config

    def measure(fs: float, log: str) -> dict[str, Any]:
        ser = open_port(port, baud)
        try:
            with open(log, "wb") as f:
                link = _Link(ser, f)
                link.settle()
                for words in ("mode allan", "interval 0", f"rate {fs:g}", "reset"):
                    reply = link.command(words)
                    if not reply.startswith("ok"):
                        raise InputError(f"{port}: '{words}' answered '{reply}'")
                if "run=0" in link.command("status"):
                    link.command("start")
                link.wait(cfg.seconds, f"{rate_key(fs)} Hz: sampling")
                rep = link.report(fs, int(cfg.seconds * fs * 0.99))
        finally:
            ser.close()
        return {"port": {"seq": rep.seq}}

    return measure


class _Link:
    """A serial link whose bytes all go to a log; replies and reports decoded on the way."""

    def __init__(self, ser: Any, log: Any) -> None:
        from ..device.stream import StreamDecoder

        self.ser, self.log, self.dec = ser, log, StreamDecoder()
        self.replies: list[str] = []
        self.reports: list[Any] = []
        self.boots: list[Any] = []
        self.received = 0

    def _pump(self) -> None:
        data = self.ser.read(4096)
        if data:
            self.received += len(data)
            self.log.write(data)
            ch = self.dec.feed(data)
            self.replies += ch.replies
            self.reports += ch.reports
            self.boots += ch.boots

    def settle(self, quiet: float = 0.5, limit: float = 3.0) -> None:
        """Opening a port may reset the board (DTR): wait for its boot line, or for
        ``quiet`` seconds of silence, before the first command (bytes sent while the
        device boots are lost)."""
        t0 = last = time.monotonic()
        while time.monotonic() - t0 < limit:
            n = len(self.boots)
            data_before = self.received
            self._pump()
            now = time.monotonic()
            if len(self.boots) > n:
                self._pump()  # what the device sends right after booting
                return
            if self.received != data_before:
                last = now
            elif now - last >= quiet:
                return

    def command(self, words: str, timeout: float = 1.5, tries: int = 3) -> str:
        """The device's reply to ``words``; sent again when no reply came (a line lost
        while the device booted, or on the radio), at most ``tries`` times."""
        for _ in range(tries):
            self.replies.clear()
            self.ser.write(command_line([words]))  # with its check, as `imu-allan cmd` sends it
            self.ser.flush()
            end = time.monotonic() + timeout
            while time.monotonic() < end:
                self._pump()
                if self.replies:
                    return self.replies.pop(0)
        raise InputError(f"no reply to '{words}' ({tries} tries, {timeout:g} s each)")

    def wait(self, seconds: float, label: str) -> None:
        t0 = time.monotonic()
        with Progress(label, seconds) as bar:
            while time.monotonic() - t0 < seconds:
                self._pump()
                bar.update(time.monotonic() - t0)

    def report(self, fs: float, n_min: int, timeout: float = 15.0) -> Any:
        self.reports.clear()
        self.command("report")
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self._pump()
            for r in self.reports:
                if abs(float(r.header.fs_hz) - fs) < 1e-9 * fs and (r.header.n or 0) >= n_min:
                    return r
        raise InputError(
            f"no complete report at {fs:g} Hz with at least {n_min} samples within {timeout:g} s of 'report'"
        )
