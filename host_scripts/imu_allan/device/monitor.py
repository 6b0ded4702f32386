"""The live side: a serial port, one command and its reply, the monitor view.

``send_command`` writes one command line and waits for its reply among
whatever else the device sends; ``Monitor`` keeps the state the live view
shows (latest complete report, replies, stream counters and rate) and
renders it; ``run_monitor`` is the loop around a port.  Everything goes
through ``stream.StreamDecoder``, so reports, raw rows and binary frames may
all be in flight at once.  pyserial is imported only here.
"""
from __future__ import annotations

import collections
import os
import sys
import threading
import time
from typing import IO, Any, Optional

from ..channels import CHANNELS
from ..errors import InputError
from .stream import StreamDecoder

READ_TIMEOUT = 0.1
"""Seconds one read of the port waits (the view's refresh granularity)."""

_CLEAR = "\x1b[H\x1b[2J"
_REPLIES_SHOWN = 5
_RATE_WINDOW = 2.0
_NON_TTY_STATS = 10.0
_SHOWN_ERRORS = ("bad_crc", "malformed", "restarted", "unparsable", "orphan_lines",
                 "incomplete_reports", "unknown_records", "garbage_bytes")


class PortError(Exception):
    """The port failed after it was opened (device unplugged, ...)."""


def open_port(port: str, baud: int, timeout: float = READ_TIMEOUT) -> Any:
    """A pyserial port, 8N1; InputError (one line) if it cannot be opened."""
    try:
        import serial  # type: ignore[import-untyped]
    except ImportError:
        raise InputError("pyserial is not installed (pip install pyserial)") from None
    try:
        return serial.Serial(port, baud, timeout=timeout)
    except (serial.SerialException, OSError, ValueError) as exc:
        errno = getattr(exc, "errno", None)
        why = os.strerror(errno) if isinstance(errno, int) else str(exc)
        raise InputError(f"cannot open port '{port}': {why}") from None


def command_line(words: list[str]) -> bytes:
    """WORDS -> the bytes of one command line (CR-ended); InputError if unsendable."""
    text = " ".join(words).strip()
    if not text:
        raise InputError("empty command")
    if not all(0x20 <= ord(ch) <= 0x7E for ch in text):
        raise InputError(f"a command is printable ASCII: {text!r}")
    return text.encode("ascii") + b"\r"


def send_command(ser: Any, line: bytes, timeout: float) -> Optional[str]:
    """Send ``line``; the body of the first intact reply within ``timeout``
    seconds (``ok ...`` or ``error:...``), or None.  Other traffic (reports,
    raw rows, binary frames, the device's echo of typed lines, garbage) is
    read and ignored.  A boot line before any reply means the device
    (re)started after the line was sent, e.g. because opening the port
    reset it, so the line never reached its command loop: it is sent again,
    once.  A multi-line reply (``ok help ...``) is returned whole, its lines
    joined by newlines."""
    import serial  # type: ignore[import-untyped]
    dec = StreamDecoder()
    resent = False
    try:
        ser.reset_input_buffer()  # a reply already waiting is not ours
        ser.write(line)
        ser.flush()
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:  # each read waits READ_TIMEOUT at most
            data = ser.read(4096)
            if data:
                chunk = dec.feed(data)
                if chunk.replies:
                    return _rest_of_reply(ser, dec, chunk.replies)
                if chunk.boots and not resent:
                    resent = True
                    ser.write(line)
                    ser.flush()
    except (serial.SerialException, OSError) as exc:
        raise PortError(str(exc)) from None
    return None


def _rest_of_reply(ser: Any, dec: StreamDecoder, replies: list[str]) -> str:
    """The further lines of a multi-line reply (``ok help <command>``, one
    per command): read while they keep coming."""
    if not replies[0].startswith("ok help "):
        return replies[0]
    lines = [r for r in replies if r.startswith("ok help ")]
    quiet_until = time.monotonic() + 0.3
    while time.monotonic() < quiet_until:
        data = ser.read(4096)
        if data:
            more = [r for r in dec.feed(data).replies if r.startswith("ok help ")]
            if more:
                lines += more
                quiet_until = time.monotonic() + 0.3
    return "\n".join(lines)


class Monitor:
    """State of the live view, fed with the bytes read from the port."""

    def __init__(self, port: str, baud: int, log_path: str, commands: bool = False) -> None:
        self.port, self.baud, self.log_path, self.commands = port, baud, log_path, commands
        self.decoder = StreamDecoder()
        self.report: Optional[Any] = None
        self.report_time = ""
        self.reports = 0
        self.replies: collections.deque[str] = collections.deque(maxlen=_REPLIES_SHOWN)
        self.sent: Optional[str] = None
        self.bytes = 0
        self._rate: collections.deque[tuple[float, int]] = collections.deque()

    def feed(self, data: bytes, now: Optional[float] = None) -> tuple[list[Any], list[str]]:
        """Decode ``data``; the new complete reports and replies."""
        self.bytes += len(data)
        chunk = self.decoder.feed(data)
        if chunk.reports:
            self.report = chunk.reports[-1]
            self.report_time = time.strftime("%H:%M:%S")
            self.reports += len(chunk.reports)
        self.replies.extend(chunk.replies)
        self.tick(time.monotonic() if now is None else now)
        return chunk.reports, chunk.replies

    def tick(self, now: float) -> None:
        self._rate.append((now, self.decoder.samples))
        while len(self._rate) > 2 and now - self._rate[1][0] >= _RATE_WINDOW:
            self._rate.popleft()

    @property
    def rate(self) -> Optional[float]:
        """Samples (raw rows and frames) per second over the last two seconds;
        None until half a second has been seen."""
        if len(self._rate) < 2:
            return None
        (t0, n0), (t1, n1) = self._rate[0], self._rate[-1]
        return (n1 - n0) / (t1 - t0) if t1 - t0 >= 0.5 else None

    def stream_line(self) -> str:
        c = self.decoder.counts
        rate = "?" if self.rate is None else f"{self.rate:.0f}"
        return (f"samples: rows {c['rows']}, frames {c['frames']} ({rate}/s); "
                f"lost: rows {c['rows_lost']}, frames {c['frames_lost']}; "
                f"bad: rows {c['bad_rows']}, frames {c['bad_frames']}")

    def errors_line(self) -> str:
        c = self.decoder.counts
        bad = [f"{k} {c[k]}" for k in _SHOWN_ERRORS if c[k]]
        return "not used: " + (", ".join(bad) if bad else "nothing")

    def report_text(self) -> str:
        from .. import render
        if self.report is None:
            return "no complete report yet\n"
        doc = render.report_doc(self.report)
        return (f"report seq {self.report.seq} (received {self.report_time}; "
                f"{self.reports} complete so far)\n"
                + render.device_header_text(doc["header"])
                + "Allan deviation, ADC counts (! flagged: saturated or range):\n"
                + render.device_adev_table(doc["rows"], CHANNELS))

    def render(self) -> str:
        lines = [f"imu-allan monitor: {self.port} at {self.baud} baud, log {self.log_path}, "
                 f"{self.bytes} bytes (Ctrl-C quits)", ""]
        text = self.report_text()
        lines.append(text.rstrip("\n"))
        lines.append("")
        lines.append(self.stream_line())
        lines.append(self.errors_line())
        lines.append("replies: " + (" | ".join(self.replies) if self.replies else "none"))
        if self.commands:
            lines.append("type a command and Enter to send it (help, status, mode raw, ...)"
                         + (f"; sent: {self.sent}" if self.sent else ""))
        return "\n".join(lines) + "\n"


def default_log_name() -> str:
    return time.strftime("imu-allan-%Y%m%d-%H%M%S.log")


def _stdin_commands(ser: Any, mon: Monitor) -> None:
    for text in sys.stdin:
        text = text.strip()
        if not text:
            continue
        try:
            ser.write(text.encode("ascii", "replace") + b"\r")
        except Exception:  # the port went away: the main loop says so
            return
        mon.sent = text


def run_monitor(port: str, baud: int, log_path: Optional[str], once: bool,
                out: Optional[IO[str]] = None, err: Optional[IO[str]] = None) -> int:
    """The monitor loop; returns the exit status (stdout and stderr by default)."""
    import serial  # type: ignore[import-untyped]
    out = out or sys.stdout
    err = err or sys.stderr
    log_path = log_path or default_log_name()
    ser = open_port(port, baud)
    try:
        log = open(log_path, "ab")
    except OSError as exc:
        ser.close()
        raise InputError(f"cannot write '{log_path}': {exc.strerror or exc}") from None
    tty = out.isatty()
    commands = sys.stdin is not None and sys.stdin.isatty()
    mon = Monitor(port, baud, log_path, commands)
    if commands:
        threading.Thread(target=_stdin_commands, args=(ser, mon), daemon=True).start()
    if not tty:
        print(f"imu-allan monitor: {port} at {baud} baud, logging to {log_path}", file=err)
    drawn = 0.0
    stats_at = time.monotonic()
    status = 0
    try:
        while True:
            try:
                data = ser.read(65536)
            except serial.SerialException as exc:
                print(f"imu-allan monitor: {port}: connection lost ({exc})", file=err)
                status = 1
                break
            now = time.monotonic()
            if data:
                try:
                    log.write(data)
                    log.flush()
                except OSError as exc:
                    print(f"imu-allan monitor: cannot write '{log_path}': {exc.strerror or exc}",
                          file=err)
                    status = 1
                    break
                reports, replies = mon.feed(data, now)
            else:
                reports, replies = [], []
                mon.tick(now)
            if tty:
                if reports or replies or now - drawn >= 0.5 or (data and now - drawn >= 0.25):
                    out.write(_CLEAR + mon.render())
                    out.flush()
                    drawn = now
            else:
                for body in replies:
                    out.write(f"reply: {body}\n")
                if reports:
                    out.write(mon.report_text() + mon.stream_line() + "\n"
                              + mon.errors_line() + "\n\n")
                if mon.decoder.samples and now - stats_at >= _NON_TTY_STATS:
                    out.write(mon.stream_line() + "\n")
                    stats_at = now
                out.flush()
            if once and reports:
                break
    except KeyboardInterrupt:
        pass
    finally:
        ser.close()
        log.close()
    if tty:
        out.write("\n")
    print(f"imu-allan monitor: {mon.reports} complete reports, {mon.stream_line()}; "
          f"log {log_path}", file=err)
    return status
