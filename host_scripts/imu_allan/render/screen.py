"""The monitor's view of a live port: ``Monitor`` keeps the state the view shows
(latest complete report, replies, stream counters and rate) and renders it as
text or cut to a terminal; ``run_screen`` (full screen, with a command line)
and ``run_plain`` (a pipe: reports and replies printed once) are the loops
over a port that cli/monitor.py opens (device/link.py)."""

from __future__ import annotations

import collections
import select
import sys
import time
from typing import IO, Any, Optional

from ..channels import CHANNELS
from ..device.link import READ_TIMEOUT, PortReader, command_line, log_write
from ..device.stream import StreamDecoder
from ..errors import InputError

_REPLIES_SHOWN = 5
_RATE_WINDOW = 2.0
_NON_TTY_STATS = 10.0
_SHOWN_ERRORS = (
    "bad_crc",
    "malformed",
    "restarted",
    "unparsable",
    "orphan_lines",
    "incomplete_reports",
    "unknown_records",
    "garbage_bytes",
    "inconsistent_reports",
    "report_check_failed",
    "inconsistent_lines",
    "seq_backwards",
)


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
        return (
            f"samples: rows {c['rows']}, frames {c['frames']} ({rate}/s); "
            f"lost: rows {c['rows_lost']}, frames {c['frames_lost']}; "
            f"bad: rows {c['bad_rows']}, frames {c['bad_frames']}"
        )

    def errors_line(self) -> str:
        c = self.decoder.counts
        bad = [f"{k} {c[k]}" for k in _SHOWN_ERRORS if c[k]]
        warnings = self.decoder.warnings
        return (
            "not used: " + (", ".join(bad) if bad else "nothing") + (f"; warning: {warnings[-1]}" if warnings else "")
        )

    def report_text(self) -> str:
        from . import text as render

        if self.report is None:
            return "no complete report yet\n"
        doc = render.report_doc(self.report)
        return (
            f"report seq {self.report.seq} (received {self.report_time}; "
            f"{self.reports} complete so far)\n"
            + self.advice_line()
            + "\n"
            + render.device_header_text(doc["header"])
            + "Allan deviation, ADC counts (! flagged: saturated or range):\n"
            + render.device_adev_table(doc["rows"], CHANNELS)
        )

    def title(self) -> str:
        return (
            f"imu-allan monitor: {self.port} at {self.baud} baud, {self.bytes} bytes "
            f"(Ctrl-C quits), log {self.log_path}"
        )

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
        lines = [
            self.title(),
            "",
            self.report_text().rstrip("\n"),
            "",
            self.stream_line(),
            self.errors_line(),
            self.replies_line(),
        ]
        if self.commands:
            lines.append(
                "type a command and Enter to send it (help, status, mode raw, ...)"
                + (f"; sent: {self.sent}" if self.sent else "")
            )
        return "\n".join(lines) + "\n"

    def screen(
        self, columns: int, rows: int, typed: Optional[str] = None, scroll: int = 0
    ) -> tuple[list[str], tuple[int, int], int]:
        """The view cut to a ``columns`` x ``rows`` terminal: the title first,
        the stream, losses, replies and the command line (``typed``, None for
        none) at the bottom, and as much of the report as fits between them,
        from line ``scroll`` on.  (lines, cursor (row, column), scroll used)."""
        foot = [self.stream_line(), self.errors_line(), self.replies_line(columns)]
        if typed is not None:
            prompt = "> " + typed
            foot.append(prompt[-(columns - 1) :] if len(prompt) >= columns else prompt)
        body = self.report_text().rstrip("\n").split("\n")
        room = max(rows - 1 - len(foot), 0)
        if len(body) > room:  # the last line of the room says what is hidden
            shown = max(room - 1, 0)
            scroll = min(max(scroll, 0), max(len(body) - shown, 0))
            more = (f"-- lines {scroll + 1}-{scroll + shown} of {len(body)}; PgUp/PgDn scroll --") if room else ""
            body = body[scroll : scroll + shown] + ([more] if room else [])
        else:
            scroll = 0
            body = body + [""] * (room - len(body))
        lines = [self.title()] + body + foot
        lines = [ln[:columns] for ln in lines][: max(rows, 1)]
        cursor = (len(lines) - 1, len(lines[-1])) if typed is not None else (len(lines) - 1, 0)
        return lines, cursor, scroll


def run_screen(ser: Any, mon: Monitor, log: IO[bytes], out: IO[str], once: bool) -> None:
    """The full-screen view: the report, counters and the command line typed
    (when stdin is a terminal too); returns on Ctrl-C (KeyboardInterrupt
    propagates), --once, or raises PortError."""
    from contextlib import nullcontext

    from .terminal import Keys, LineEditor, Screen

    reader = PortReader(ser, mon.port)
    editor = LineEditor()
    scroll = 0
    with Screen(out) as scr, Keys(sys.stdin) if mon.commands else nullcontext() as keys:
        fds = [reader.fd] + ([keys.fd] if keys is not None else [])
        drawn = 0.0
        while True:
            ready = select.select(fds, [], [], READ_TIMEOUT)[0]
            now = time.monotonic()
            data = reader.read() if reader.fd in ready else b""
            dirty = scr.resized()
            if data:
                log_write(log, data, mon.log_path)
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
                scroll += sum(page if k == "page_down" else -page if k == "page_up" else 0 for k in pressed)
                dirty = True
            if dirty or now - drawn >= 0.5 or (data and now - drawn >= 0.25):
                lines_, cursor, scroll = mon.screen(
                    scr.columns, scr.lines, editor.text if keys is not None else None, scroll
                )
                scr.draw(lines_, cursor)
                drawn = now
            if once and reports:
                return


def run_plain(ser: Any, mon: Monitor, log: IO[bytes], out: IO[str], once: bool) -> None:
    """Not a terminal: each report and reply printed once, stream counts every
    10 s; returns on --once or raises PortError / KeyboardInterrupt."""
    reader = PortReader(ser, mon.port)
    stats_at = time.monotonic()
    while True:
        ready = select.select([reader.fd], [], [], READ_TIMEOUT)[0]
        now = time.monotonic()
        data = reader.read() if ready else b""
        reports: list[Any] = []
        if data:
            log_write(log, data, mon.log_path)
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
