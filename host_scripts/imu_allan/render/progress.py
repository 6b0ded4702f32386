"""A plain progress line on stderr, shown only on a terminal and only for long
work.  The work itself (device/, analysis/) asks progress.py, at rank 0, for its
line; the command line installs this one there (cli/main.py)."""

from __future__ import annotations

import os
import sys
import time
from typing import Optional, TextIO


def _columns(stream: TextIO) -> int:
    """The terminal's width for ``stream`` (80 if it cannot be asked)."""
    try:
        return os.get_terminal_size(stream.fileno()).columns or 80
    except (AttributeError, OSError, ValueError):  # io.UnsupportedOperation is both
        return 80


def _si(v: float) -> str:
    """1234567 -> '1.23 M' (a rate on a progress line)."""
    for div, p in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if v >= div:
            return f"{v / div:.3g} {p}"
    return f"{v:.3g}"


class Progress:
    """``with Progress("reading", total) as p: p.update(done)``.

    Draws nothing unless the stream is a TTY and the work has lasted more
    than ``delay`` seconds; redraws at most 10 times a second; erases itself
    at the end. ``total`` may be unknown (None): then it counts. ``show``
    draws a line of the caller's own. A line never wraps (it is cut to the
    terminal's width less one column), so a carriage return reaches its
    start, and the erase overwrites exactly the columns last written.
    """

    def __init__(
        self,
        label: str,
        total: Optional[float] = None,
        stream: Optional[TextIO] = None,
        delay: float = 0.5,
        unit: str = "",
    ) -> None:
        self.label = label
        self.total = total
        self.stream = stream if stream is not None else sys.stderr
        self.delay = delay
        self.unit = unit
        self.start = time.monotonic()
        self.last = 0.0
        self.width = 0  # columns on screen now (0: nothing drawn)
        try:
            self.enabled = bool(self.stream.isatty())
        except (AttributeError, ValueError):
            self.enabled = False

    @property
    def drawn(self) -> bool:
        return self.width > 0

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _due(self) -> Optional[float]:
        if not self.enabled:
            return None
        now = time.monotonic()
        if now - self.start < self.delay or now - self.last < 0.1:
            return None
        self.last = now
        return now

    def update(self, done: float) -> None:
        now = self._due()
        if now is None:
            return
        rate = done / max(now - self.start, 1e-9)
        speed = f"  {_si(rate)}{self.unit}/s" if self.unit else ""
        if self.total:
            frac = min(max(done / self.total, 0.0), 1.0)
            width = 20 if self.unit else 30
            bar = "#" * int(frac * width) + "-" * (width - int(frac * width))
            # the total may be an estimate (a file's size over a typical row): no ETA past it
            eta = f"  {(self.total - done) / rate:4.0f} s left" if frac < 1 and rate > 0 else ""
            counted = f"  {done:,.0f}{self.unit}" if self.unit else ""
            text = f"{self.label} [{bar}] {frac * 100:5.1f}%{counted}{speed}{eta}"
        else:
            text = f"{self.label} {done:,.0f}{self.unit}{speed}"
        self._draw(text)

    def show(self, text: str) -> None:
        """Draw ``text`` (after the label) as the progress line, at the same pace."""
        if self._due() is not None:
            self._draw(f"{self.label} {text}")

    def _draw(self, text: str) -> None:
        text = text[: max(_columns(self.stream) - 1, 1)]
        pad = " " * max(self.width - len(text), 0)  # what a longer line left behind
        self.stream.write("\r" + text + pad + "\b" * len(pad))
        self.stream.flush()
        self.width = len(text)

    def close(self) -> None:
        if self.drawn:
            self.stream.write("\r" + " " * self.width + "\r")
            self.stream.flush()
            self.width = 0
