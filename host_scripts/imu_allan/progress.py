"""A plain progress bar on stderr, shown only on a terminal and only for long work."""
from __future__ import annotations

import sys
import time
from typing import Optional, TextIO


class Progress:
    """``with Progress("reading", total) as p: p.update(done)``.

    Draws nothing unless the stream is a TTY and the work has lasted more
    than ``delay`` seconds; redraws at most 10 times a second; erases itself
    at the end. ``total`` may be unknown (None): then it counts.
    """

    def __init__(self, label: str, total: Optional[float] = None, stream: Optional[TextIO] = None,
                 delay: float = 0.5, unit: str = "") -> None:
        self.label = label
        self.total = total
        self.stream = stream if stream is not None else sys.stderr
        self.delay = delay
        self.unit = unit
        self.start = time.monotonic()
        self.last = 0.0
        self.drawn = False
        try:
            self.enabled = bool(self.stream.isatty())
        except (AttributeError, ValueError):
            self.enabled = False

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def update(self, done: float) -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        if now - self.start < self.delay or now - self.last < 0.1:
            return
        self.last = now
        if self.total:
            frac = min(max(done / self.total, 0.0), 1.0)
            width = 30
            bar = "#" * int(frac * width) + "-" * (width - int(frac * width))
            eta = (now - self.start) * (1 - frac) / frac if frac > 0 else 0.0
            text = f"\r{self.label} [{bar}] {frac * 100:5.1f}%  {eta:5.0f} s left "
        else:
            text = f"\r{self.label} {done:,.0f}{self.unit} "
        self.stream.write(text)
        self.stream.flush()
        self.drawn = True

    def close(self) -> None:
        if self.drawn:
            self.stream.write("\r" + " " * 72 + "\r")
            self.stream.flush()
            self.drawn = False
