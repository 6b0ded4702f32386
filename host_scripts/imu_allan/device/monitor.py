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
import errno as _errno
import os
import select
import sys
import time
from typing import IO, Any, Optional

from ..channels import CHANNELS
from ..errors import InputError
from .framing import crc16
from .stream import StreamDecoder

READ_TIMEOUT = 0.1
"""Seconds one read of the port waits (the view's refresh granularity)."""

_REPLIES_SHOWN = 5
_RATE_WINDOW = 2.0
_NON_TTY_STATS = 10.0
_SHOWN_ERRORS = ("bad_crc", "malformed", "restarted", "unparsable", "orphan_lines",
                 "incomplete_reports", "unknown_records", "garbage_bytes", "inconsistent_reports",
                 "report_check_failed", "inconsistent_lines", "seq_backwards")


class PortError(Exception):
    """The port failed after it was opened (device unplugged, ...)."""


def open_port(port: str, baud: int, timeout: float = READ_TIMEOUT) -> Any:
    """A pyserial port, 8N1, locked for this process alone (flock, which
    pyserial, picocom and minicom honour): a second imu-allan on the same
    port gets InputError "port busy" and the first one keeps it.  InputError
    (one line) if it cannot be opened."""
    try:
        import serial  # type: ignore[import-untyped]
    except ImportError:
        raise InputError("pyserial is not installed (pip install pyserial)") from None
    try:
        return serial.Serial(port, baud, timeout=timeout, exclusive=True)
    except (serial.SerialException, OSError, ValueError) as exc:
        errno = getattr(exc, "errno", None)
        if errno in (_errno.EAGAIN, _errno.EWOULDBLOCK, _errno.EBUSY):
            raise InputError(f"port busy: '{port}' is open in another program "
                             "(imu-allan monitor, a terminal?); close it first") from None
        why = os.strerror(errno) if isinstance(errno, int) else str(exc)
        raise InputError(f"cannot open port '{port}': {why}") from None


def command_line(words: list[str]) -> bytes:
    """WORDS -> the bytes of one command line, ``text*XXXX`` CR: the text
    and its check, the CRC-16 of the text in 4 upper-case hex digits, the
    same CRC as the device's own lines (docs/protocol.md, "Commands"), so
    that a bit flipped on the way makes the device refuse the line
    (``error:5``) instead of running another command.  InputError if
    unsendable."""
    text = " ".join(words).strip()
    if not text:
        raise InputError("empty command")
    if not all(0x20 <= ord(ch) <= 0x7E for ch in text):
        raise InputError(f"a command is printable ASCII: {text!r}")
    if "*" in text:
        raise InputError(f"a command holds no '*' (it starts the line's check): {text!r}")
    raw = text.encode("ascii")
    return b"%s*%04X\r" % (raw, crc16(raw))


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
        warnings = self.decoder.warnings
        return ("not used: " + (", ".join(bad) if bad else "nothing")
                + (f"; warning: {warnings[-1]}" if warnings else ""))

    def report_text(self) -> str:
        from ..render import text as render
        if self.report is None:
            return "no complete report yet\n"
        doc = render.report_doc(self.report)
        return (f"report seq {self.report.seq} (received {self.report_time}; "
                f"{self.reports} complete so far)\n"
                + self.advice_line() + "\n"
                + render.device_header_text(doc["header"])
                + "Allan deviation, ADC counts (! flagged: saturated or range):\n"
                + render.device_adev_table(doc["rows"], CHANNELS))

    def title(self) -> str:
        return (f"imu-allan monitor: {self.port} at {self.baud} baud, {self.bytes} bytes "
                f"(Ctrl-C quits), log {self.log_path}")

    def replies_line(self, columns: int = 0) -> str:
        """The last replies, oldest first; with ``columns``, as many of the
        newest as fit."""
        shown = list(self.replies)
        while columns and len(shown) > 1 and len("replies: " + " | ".join(shown)) > columns:
            shown.pop(0)
        return "replies: " + (" | ".join(shown) if shown else "none")

    def advice_line(self, columns: int = 80) -> str:
        """How long to record, from the last report alone (advice.py); updated at every report."""
        from ..analysis.advice import monitor_line
        return monitor_line(self.report, columns) if self.report is not None else ""

    def render(self) -> str:
        """The whole view as text (a pipe, or a test)."""
        lines = [self.title(), "", self.report_text().rstrip("\n"), "", self.stream_line(),
                 self.errors_line(), self.replies_line()]
        if self.commands:
            lines.append("type a command and Enter to send it (help, status, mode raw, ...)"
                         + (f"; sent: {self.sent}" if self.sent else ""))
        return "\n".join(lines) + "\n"

    def screen(self, columns: int, rows: int, typed: Optional[str] = None,
               scroll: int = 0) -> tuple[list[str], tuple[int, int], int]:
        """The view cut to a ``columns`` x ``rows`` terminal: the title first,
        the stream, losses, replies and the command line (``typed``, None for
        none) at the bottom, and as much of the report as fits between them,
        from line ``scroll`` on.  (lines, cursor (row, column), scroll used)."""
        foot = [self.stream_line(), self.errors_line(), self.replies_line(columns)]
        if typed is not None:
            prompt = "> " + typed
            foot.append(prompt[-(columns - 1):] if len(prompt) >= columns else prompt)
        body = self.report_text().rstrip("\n").split("\n")
        room = max(rows - 1 - len(foot), 0)
        if len(body) > room:  # the last line of the room says what is hidden
            shown = max(room - 1, 0)
            scroll = min(max(scroll, 0), max(len(body) - shown, 0))
            more = (f"-- lines {scroll + 1}-{scroll + shown} of {len(body)}; "
                    "PgUp/PgDn scroll --") if room else ""
            body = body[scroll:scroll + shown] + ([more] if room else [])
        else:
            scroll = 0
            body = body + [""] * (room - len(body))
        lines = [self.title()] + body + foot
        lines = [ln[:columns] for ln in lines][: max(rows, 1)]
        cursor = (len(lines) - 1, len(lines[-1])) if typed is not None else (len(lines) - 1, 0)
        return lines, cursor, scroll


def default_log_name() -> str:
    return time.strftime("imu-allan-%Y%m%d-%H%M%S.log")


class _PortReader:
    """Reads what the port has, without waiting.  Tells a lost port (the
    device unplugged, the simulator ended) from a read that another program
    on the same port won, which must not end the monitor."""

    LOST_EMPTY_READS = 200
    LOST_AFTER_S = 2.0

    def __init__(self, ser: Any, port: str) -> None:
        self.ser, self.port = ser, port
        self.fd = ser.fileno()
        self._empty = 0
        self._empty_since = 0.0

    def read(self) -> bytes:
        """The bytes waiting (maybe none); PortError when the port is gone."""
        try:
            data = os.read(self.fd, 65536)
        except BlockingIOError:  # another reader took them between select and read
            return b""
        except OSError as exc:
            raise PortError(os.strerror(exc.errno) if exc.errno else str(exc)) from None
        if data:
            self._empty = 0
            return data
        # Readable but nothing read: a hang-up, or a race with another reader.
        now = time.monotonic()
        if self._empty == 0:
            self._empty_since = now
        self._empty += 1
        if not os.path.exists(self.port) or (self._empty >= self.LOST_EMPTY_READS
                                              and now - self._empty_since >= self.LOST_AFTER_S):
            raise PortError("the device hung up")
        if self._empty > 20:
            time.sleep(0.01)  # a hang-up makes select return at once: do not spin
        return b""


def _log_write(log: IO[bytes], data: bytes, log_path: str) -> None:
    try:
        log.write(data)
        log.flush()
    except OSError as exc:
        raise PortError(f"cannot write '{log_path}': {exc.strerror or exc}") from None


def _run_terminal(ser: Any, mon: Monitor, log: IO[bytes], out: IO[str], once: bool) -> None:
    """The full-screen view: the report, counters and the command line typed
    (when stdin is a terminal too); returns on Ctrl-C (KeyboardInterrupt
    propagates), --once, or raises PortError."""
    from contextlib import nullcontext

    from ..render.terminal import Keys, LineEditor, Screen
    reader = _PortReader(ser, mon.port)
    editor = LineEditor()
    scroll = 0
    with Screen(out) as scr, (Keys(sys.stdin) if mon.commands else nullcontext()) as keys:
        fds = [reader.fd] + ([keys.fd] if keys is not None else [])
        drawn = 0.0
        while True:
            ready = select.select(fds, [], [], READ_TIMEOUT)[0]
            now = time.monotonic()
            data = reader.read() if reader.fd in ready else b""
            dirty = scr.resized()
            if data:
                _log_write(log, data, mon.log_path)
                reports, replies = mon.feed(data, now)
                dirty = dirty or bool(reports or replies)
            else:
                reports = []
                mon.tick(now)
            if keys is not None and (keys.fd in ready or editor.pending):
                typed = keys.read() if keys.fd in ready else b""
                if keys.fd in ready and not typed:  # end of input: watch only
                    fds.remove(keys.fd)
                lines, pressed = editor.feed(typed, final=not typed)
                for text in lines:
                    try:
                        ser.write(command_line([text]))
                        mon.sent = text
                    except InputError as exc:
                        mon.sent = f"not sent: {exc}"
                page = max(scr.lines - 6, 1)
                scroll += sum(page if k == "page_down" else -page if k == "page_up" else 0
                              for k in pressed)
                dirty = True
            if dirty or now - drawn >= 0.5 or (data and now - drawn >= 0.25):
                lines_, cursor, scroll = mon.screen(scr.columns, scr.lines,
                                                    editor.text if keys is not None else None,
                                                    scroll)
                scr.draw(lines_, cursor)
                drawn = now
            if once and reports:
                return


def _run_plain(ser: Any, mon: Monitor, log: IO[bytes], out: IO[str], once: bool) -> None:
    """Not a terminal: each report and reply printed once, stream counts every
    10 s; returns on --once or raises PortError / KeyboardInterrupt."""
    reader = _PortReader(ser, mon.port)
    stats_at = time.monotonic()
    while True:
        ready = select.select([reader.fd], [], [], READ_TIMEOUT)[0]
        now = time.monotonic()
        data = reader.read() if ready else b""
        reports: list[Any] = []
        if data:
            _log_write(log, data, mon.log_path)
            reports, replies = mon.feed(data, now)
            for body in replies:
                out.write(f"reply: {body}\n")
        else:
            mon.tick(now)
        if reports:
            out.write(mon.report_text() + mon.stream_line() + "\n" + mon.errors_line() + "\n\n")
        if mon.decoder.samples and now - stats_at >= _NON_TTY_STATS:
            out.write(mon.stream_line() + "\n")
            stats_at = now
        out.flush()
        if once and reports:
            return


def run_monitor(port: str, baud: int, log_path: Optional[str], once: bool,
                out: Optional[IO[str]] = None, err: Optional[IO[str]] = None) -> int:
    """The monitor: a full-screen view when ``out`` (stdout by default) is a
    terminal, taking commands typed on stdin when that is a terminal too;
    plain lines otherwise.  Returns the exit status (0, or 1 when the port
    or the log fails)."""
    from ..render.terminal import stdin_is_terminal
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
    mon = Monitor(port, baud, log_path, commands=tty and stdin_is_terminal())
    if not tty:
        print(f"imu-allan monitor: {port} at {baud} baud, logging to {log_path}", file=err)
    status = 0
    try:
        (_run_terminal if tty else _run_plain)(ser, mon, log, out, once)
        if tty and once:  # the full screen is gone: leave what --once waited for
            out.write(mon.render())
    except PortError as exc:
        why = str(exc)
        print(f"imu-allan monitor: {port}: " + (why if why.startswith("cannot write")
                                                 else f"connection lost ({why})"), file=err)
        status = 1
    except KeyboardInterrupt:
        pass
    finally:
        ser.close()
        log.close()
    print(f"imu-allan monitor: {mon.reports} complete reports, {mon.stream_line()}; "
          f"log {log_path}", file=err)
    return status
