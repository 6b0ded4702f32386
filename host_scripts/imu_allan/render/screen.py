"""The monitor's view of a live port: ``Monitor`` keeps the state the view shows
(latest complete report, the conversation with the device, the link's
counters and rate) and renders it as text or fitted to a terminal;
``run_screen`` (full screen, with a command line) and ``run_plain`` (a pipe:
reports and replies printed once) are the loops over a port that
cli/monitor.py opens (device/link.py).

The full screen, top to bottom: the title; the status line (the latest
report's age, the link's lines ok and bad, drops, the sample rate); what was
not used, when anything was; the recording advice (analysis/advice.py); the
latest report (the device's own summary, its noise terms first, then the
header and the table in ADC counts; PgUp/PgDn scroll what does not fit);
the conversation (each command sent, ``> text``, and every line of its reply,
the newest exchange shown whole when the terminal can hold it); the command
line.  Every line longer than the terminal is wrapped (render/wrap.py),
never cut."""

from __future__ import annotations

import collections
import select
import sys
import time
from typing import IO, Any, Optional

from ..channels import CHANNELS
from ..device.framing import LINE_ERRORS
from ..device.link import READ_TIMEOUT, PortReader, command_line, log_write
from ..device.stream import StreamDecoder
from ..device.summary import TERM_ROWS
from ..errors import InputError
from .wrap import last_rows, wrap, wrap_all

_RATE_WINDOW = 2.0
_NON_TTY_STATS = 10.0
_CONVERSATION_KEPT = 500
"""Lines of the conversation kept (the screen shows the newest)."""
_CONVERSATION_MIN = 3
"""Rows the conversation keeps under the report once anything was said."""
_SHOWN_SAID = 20
"""Lines of the conversation the text view (a pipe, --once) ends with."""
_REPORT_MIN = 3
"""Rows the report keeps above a long reply (two lines and the scroll mark)."""
_BAD_LINES = tuple(k for k in LINE_ERRORS if k != "garbage_bytes") + ("bad_rows",)
"""The decoder's counters of lines that came damaged (garbage is bytes, not lines)."""
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
        self.report_at: Optional[float] = None  # time.monotonic() when it came
        self.reports = 0
        self.said: collections.deque[str] = collections.deque(maxlen=_CONVERSATION_KEPT)
        """The conversation: each command sent (``> text``), reply line and boot, oldest first."""
        self.exchange = 0
        """How many of the newest lines of ``said`` belong to the last command's exchange."""
        self.bytes = 0
        self._rate: collections.deque[tuple[float, int]] = collections.deque()

    def feed(self, data: bytes, now: Optional[float] = None) -> tuple[list[Any], list[str]]:
        """Decode ``data``; the new complete reports and replies."""
        now = time.monotonic() if now is None else now
        self.bytes += len(data)
        chunk = self.decoder.feed(data)
        if chunk.reports:
            self.report = chunk.reports[-1]
            self.report_time = time.strftime("%H:%M:%S")
            self.report_at = now
            self.reports += len(chunk.reports)
        for boot in chunk.boots:
            reset = "+".join(boot.reset_cause or []) or "?"
            self._say(f"device started: fw {boot.fw or '?'}, mcu {boot.mcu or '?'}, reset {reset}")
        for body in chunk.replies:
            self._say(body)
        self.tick(now)
        return chunk.reports, chunk.replies

    def _say(self, text: str) -> None:
        self.said.append(text)
        self.exchange = min(self.exchange + 1, len(self.said))

    def sent(self, text: str, refused: Optional[str] = None) -> None:
        """A command line typed (sent, or ``refused`` with the reason): a new exchange."""
        self.said.append(f"> {text}" + (f"  (not sent: {refused})" if refused else ""))
        self.exchange = 1

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

    def device_drops(self) -> int:
        """Sample sets the device itself lost: its latest report's ``drops``
        (since its reset) or, in raw and binary modes, its count lines' (the larger)."""
        h = self.report.header.drops if self.report is not None else None
        return max(h or 0, self.decoder.counts["device_drops"])

    def status_line(self, now: Optional[float] = None) -> str:
        """The latest report's age and the link's counters: intact lines
        (framed lines and raw rows) and damaged ones, binary frames when
        any came, drops on the device and samples lost on the link, the rate."""
        c = self.decoder.counts
        if self.report is None or self.report_at is None:
            parts = ["no report yet"]
        else:
            from ..analysis.advice import fmt_time

            age = max((time.monotonic() if now is None else now) - self.report_at, 0.0)
            parts = [f"report seq {self.report.seq}, {fmt_time(age)} ago"]
        parts.append(f"lines ok {self.decoder.text_lines + c['rows']}, bad {sum(c[k] for k in _BAD_LINES)}")
        if c["frames"] or c["bad_frames"]:
            parts.append(f"frames ok {c['frames']}, bad {c['bad_frames']}")
        parts.append(f"drops: device {self.device_drops()}, link {c['rows_lost'] + c['frames_lost']}")
        if self.decoder.samples:
            parts.append("? samples/s" if self.rate is None else f"{self.rate:.0f} samples/s")
        return "; ".join(parts)

    def errors_line(self) -> str:
        c = self.decoder.counts
        bad = [f"{k} {c[k]}" for k in _SHOWN_ERRORS if c[k]]
        warnings = self.decoder.warnings
        return (
            "not used: " + (", ".join(bad) if bad else "nothing") + (f"; warning: {warnings[-1]}" if warnings else "")
        )

    def anything_unused(self) -> bool:
        return bool(self.decoder.warnings) or any(self.decoder.counts[k] for k in _SHOWN_ERRORS)

    def report_text(self) -> str:
        """The latest report as text (a pipe): what the host decoded, then the
        device's own summary as it printed it, last (the end of a scrolling
        terminal is what stays in view)."""
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
            + "".join(f"  left out: {why}\n" for why in self.report.refused)
            + "Allan deviation, ADC counts (! flagged: saturated or range):\n"
            + render.device_adev_table(doc["rows"], CHANNELS)
            + "".join(f"{text}\n" for text in self.report.summary)
        )

    def report_rows(self) -> list[str]:
        """The latest report for the screen, the answer first: the device's
        summary with its noise terms (N, B) before its deviation table, then
        the header and the table in ADC counts that the host decoded."""
        from . import text as render

        if self.report is None:
            return ["no complete report yet" + ("; type report to ask for one now" if self.commands else "")]
        rep = self.report
        doc = render.report_doc(rep)
        return (
            summary_terms_first(rep.summary)
            + [f"header of report seq {rep.seq}, received {self.report_time} ({self.reports} complete so far):"]
            + render.device_header_text(doc["header"]).rstrip("\n").split("\n")
            + [f"  left out: {why}" for why in rep.refused]
            + ["Allan deviation, ADC counts (! flagged: saturated or range):"]
            + render.device_adev_table(doc["rows"], CHANNELS).rstrip("\n").split("\n")
        )

    def title(self) -> str:
        return f"imu-allan monitor: {self.port} at {self.baud} baud, log {self.log_path} (Ctrl-C quits)"

    def advice_line(self, columns: int = 80) -> str:
        """How long to record, from the last report alone (advice.py); updated at every report."""
        from ..analysis.advice import monitor_line

        return monitor_line(self.report, columns) if self.report is not None else ""

    def advice_rows(self, columns: int) -> list[str]:
        """The advice in one row when it fits (advice.py drops its N part to
        fit), wrapped whole otherwise."""
        if self.report is None:
            return []
        fit = self.advice_line(columns)
        whole = self.advice_line(1 << 16)
        return [fit] if len(fit) < columns or fit == whole else wrap(whole, columns)

    def render(self, now: Optional[float] = None) -> str:
        """The whole view as text (a pipe, or a test)."""
        lines = [self.title(), self.status_line(now), "", self.report_text().rstrip("\n"), ""]
        lines += [self.stream_line(), self.errors_line()]
        lines += list(self.said)[-_SHOWN_SAID:] or ["nothing said yet"]
        if self.commands:
            lines.append("type a command and Enter to send it (help, status, mode raw, ...)")
        return "\n".join(lines) + "\n"

    def screen(
        self,
        columns: int,
        rows: int,
        typed: Optional[str] = None,
        scroll: int = 0,
        now: Optional[float] = None,
    ) -> tuple[list[str], tuple[int, int], int]:
        """The view fitted to a ``columns`` x ``rows`` terminal (the module
        says the order), the report from row ``scroll`` of its own on.
        (lines, cursor (row, column), scroll used)."""
        top = wrap(self.title(), columns) + wrap(self.status_line(now), columns)
        if self.anything_unused():
            top += wrap(self.errors_line(), columns)
        top += self.advice_rows(columns)
        foot = [last_rows("> " + typed, columns)] if typed is not None else []
        top = top[: max(rows - len(foot), 0)]  # a terminal smaller than the fixed lines
        room = max(rows - len(top) - len(foot), 0)
        talk = self._talk_rows(columns, max(room - _REPORT_MIN, 0))
        body, scroll = _scrolled(wrap_all(self.report_rows(), columns), room - len(talk), scroll, columns)
        lines = top + body + talk + foot
        cursor = (len(lines) - 1, len(lines[-1]) if typed is not None else 0)
        return lines, cursor, scroll

    def _talk_rows(self, columns: int, most: int) -> list[str]:
        """The conversation's newest rows: the last exchange whole when ``most``
        rows hold it, at least the last few lines otherwise."""
        said = wrap_all(list(self.said), columns)
        newest = len(wrap_all(list(self.said)[len(self.said) - self.exchange :], columns))
        height = min(len(said), max(newest, _CONVERSATION_MIN), most)
        if height <= 0:
            return []
        if newest > height >= 2:  # the start of the exchange is above: say so
            hidden = newest - height + 1
            return [f"-- {hidden} lines above; a taller terminal shows them --"[:columns]] + said[-(height - 1) :]
        return said[-height:]


def summary_terms_first(summary: list[str]) -> list[str]:
    """The device's summary lines as it printed them, its noise-terms block
    (the ``N at ...`` caption and its rows) moved before the deviation table,
    under the table's channel heading (``tau_s`` blanked: those rows are not taus)."""
    at = next((i for i, text in enumerate(summary) if text.startswith("N at ")), None)
    if at is None:
        return list(summary)
    terms = summary[at : at + 1 + len(TERM_ROWS)]
    table = summary[:at] + summary[at + 1 + len(TERM_ROWS) :]
    heading = next((t for t in table if t.split()[:1] == ["tau_s"]), None)
    names = [heading.replace("tau_s", "     ", 1)] if heading is not None else []
    return terms[:1] + names + terms[1:] + table


def _scrolled(body: list[str], room: int, scroll: int, columns: int) -> tuple[list[str], int]:
    """``body`` in ``room`` rows from row ``scroll``: when it does not fit, the
    last row says which rows are shown.  (rows, scroll used)"""
    room = max(room, 0)
    if len(body) <= room:
        return body + [""] * (room - len(body)), 0
    if room == 0:
        return [], scroll
    shown = room - 1
    scroll = min(max(scroll, 0), max(len(body) - shown, 0))
    first, last = scroll + 1, scroll + shown
    more = f"-- lines {first}-{last} of {len(body)}; PgUp/PgDn scroll --"
    if len(more) > columns:
        more = f"-- {first}-{last} of {len(body)} --"
    return body[scroll : scroll + shown] + [more[:columns]], scroll


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
                        mon.sent(text)
                    except InputError as exc:
                        mon.sent(text, refused=str(exc))
                page = max(scr.lines - 6, 1)
                scroll += sum(page if k == "page_down" else -page if k == "page_up" else 0 for k in pressed)
                dirty = True
            if dirty or now - drawn >= 0.5 or (data and now - drawn >= 0.25):
                lines_, cursor, scroll = mon.screen(
                    scr.columns, scr.lines, editor.text if keys is not None else None, scroll, now
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
