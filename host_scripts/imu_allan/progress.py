"""Progress of long work, without drawing it: the callback type the statistics
take, and the progress line device/ and analysis/ ask for.  Nothing is drawn
unless a drawer is installed: the command line installs the stderr line of
render/progress.py (``use``); a library caller gets the quiet one."""

from __future__ import annotations

import time
from typing import Any, Callable, Optional

ProgressFn = Optional[Callable[[int], None]]
"""Called with the work done so far (a progress line's ``update`` fits)."""


class Quiet:
    """The progress line that draws nothing (same calls as render/progress.Progress)."""

    enabled = False
    drawn = False

    def __init__(self, label: str = "", total: Optional[float] = None, **_: Any) -> None:
        self.label, self.total = label, total
        self.start = time.monotonic()

    def __enter__(self) -> "Quiet":
        return self

    def __exit__(self, *exc: object) -> None:
        pass

    def update(self, done: float) -> None:
        pass

    def show(self, text: str) -> None:
        pass

    def close(self) -> None:
        pass


_drawer: Callable[..., Any] = Quiet


def use(drawer: Callable[..., Any]) -> None:
    """Install the progress line that ``Progress`` makes from now on."""
    global _drawer
    _drawer = drawer


def Progress(label: str, total: Optional[float] = None, **kw: Any) -> Any:
    """``with Progress("reading", total) as p: p.update(done)``: the installed
    progress line (``stream``, ``delay``, ``unit`` passed on), or a quiet one."""
    return _drawer(label, total, **kw)
