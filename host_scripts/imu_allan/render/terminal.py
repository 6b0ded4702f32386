"""A full-screen view on a terminal, and the line a person types into it.

``Screen`` draws whole frames on the alternate screen (so the scrollback
keeps what was there before, and no redraw ever scrolls: every line is put
at its own row and cut to the width), re-reads the size on SIGWINCH, and
restores the terminal on exit.  ``Keys`` puts the input terminal in cbreak
mode without echo (Ctrl-C still interrupts) and ``LineEditor`` turns the
bytes typed into edits of one command line.  Standard library only.
"""

from __future__ import annotations

import os
import signal
import sys
from typing import IO, Any, Optional

ALT_ON, ALT_OFF = "\x1b[?1049h", "\x1b[?1049l"
HIDE, SHOW = "\x1b[?25l", "\x1b[?25h"


def _size(stream: IO[str]) -> tuple[int, int]:
    """(columns, lines) of ``stream``'s terminal; 80x24 if it cannot be asked."""
    try:
        size = os.get_terminal_size(stream.fileno())
        return max(size.columns, 20), max(size.lines, 5)
    except (AttributeError, OSError, ValueError):
        return 80, 24


class Screen:
    """``with Screen(out) as s: s.draw(lines, cursor)``: frames in place."""

    def __init__(self, out: IO[str]) -> None:
        self.out = out
        self.columns, self.lines = _size(out)
        self._resized = False
        self._old_winch: Any = None

    def __enter__(self) -> "Screen":
        if hasattr(signal, "SIGWINCH"):
            try:
                self._old_winch = signal.signal(signal.SIGWINCH, self._on_winch)
            except ValueError:  # not the main thread: the size is read at each draw
                self._old_winch = None
        self.out.write(ALT_ON + "\x1b[H\x1b[2J")
        self.out.flush()
        return self

    def __exit__(self, *exc: object) -> None:
        self.out.write(SHOW + ALT_OFF)
        self.out.flush()
        if self._old_winch is not None:
            signal.signal(signal.SIGWINCH, self._old_winch)

    def _on_winch(self, signum: int, frame: Any) -> None:
        self._resized = True

    def resized(self) -> bool:
        """Whether the size changed since the last call (and take the new one)."""
        if self._resized:
            self._resized = False
            self.columns, self.lines = _size(self.out)
            return True
        return False

    def draw(self, lines: list[str], cursor: Optional[tuple[int, int]] = None) -> None:
        """Put ``lines`` (at most ``self.lines``, each cut to the width) at rows
        1..n, clear the rest, and leave the cursor at (row, column), 0-based."""
        parts = [HIDE]
        for row, text in enumerate(lines[: self.lines]):
            parts.append(f"\x1b[{row + 1};1H\x1b[2K{text[: self.columns]}")
        if len(lines) < self.lines:
            parts.append(f"\x1b[{len(lines) + 1};1H\x1b[J")
        if cursor is not None:
            row, col = cursor
            parts.append(f"\x1b[{min(row, self.lines - 1) + 1};{min(col, self.columns - 1) + 1}H" + SHOW)
        self.out.write("".join(parts))
        self.out.flush()


class Keys:
    """``with Keys(stdin) as k: data = k.read()``: cbreak, no echo, restored
    on exit (also after an exception or Ctrl-C)."""

    def __init__(self, stream: IO[str]) -> None:
        self.fd = stream.fileno()
        self._saved: Any = None

    def __enter__(self) -> "Keys":
        import termios
        import tty

        self._saved = termios.tcgetattr(self.fd)
        tty.setcbreak(self.fd, termios.TCSANOW)
        attrs = termios.tcgetattr(self.fd)
        attrs[3] &= ~termios.ECHO
        termios.tcsetattr(self.fd, termios.TCSANOW, attrs)
        return self

    def __exit__(self, *exc: object) -> None:
        import termios

        if self._saved is not None:
            termios.tcsetattr(self.fd, termios.TCSAFLUSH, self._saved)

    def read(self) -> bytes:
        return os.read(self.fd, 1024)


# Keys the editor understands besides printable ASCII.
_SEQUENCES = {
    b"\x1b[A": "up",
    b"\x1bOA": "up",
    b"\x1b[B": "down",
    b"\x1bOB": "down",
    b"\x1b[5~": "page_up",
    b"\x1b[6~": "page_down",
    b"\x1b[C": "",
    b"\x1b[D": "",
    b"\x1bOC": "",
    b"\x1bOD": "",
    b"\x1b[H": "",
    b"\x1b[F": "",
}


class LineEditor:
    """One command line: printable ASCII is typed, Backspace or DEL erases a
    character, Ctrl-U or a lone Esc drops the line, Enter submits it; Up and
    Down walk the lines sent before; PgUp and PgDn are returned as keys."""

    def __init__(self, history: int = 50) -> None:
        self.text = ""
        self.history: list[str] = []
        self._limit = history
        self._at: Optional[int] = None
        self._pending = b""

    @property
    def pending(self) -> bool:
        """An Esc is waiting to be told apart from the start of a key's sequence."""
        return bool(self._pending)

    def feed(self, data: bytes, final: bool = True) -> tuple[list[str], list[str]]:
        """Edit with ``data``; (lines submitted, other keys pressed).  With
        ``final`` a lone Esc at the end is a key of its own, not the start of
        a sequence still to come."""
        data = self._pending + data
        self._pending = b""
        lines: list[str] = []
        keys: list[str] = []
        i = 0
        while i < len(data):
            ch = data[i : i + 1]
            if ch == b"\x1b":
                seq = self._sequence(data[i:])
                if seq is None and not final:  # wait for the rest
                    self._pending = data[i:]
                    break
                if seq is None or seq == b"\x1b":
                    self.text, self._at = "", None
                    i += 1
                    continue
                key = _SEQUENCES.get(seq, "")
                if key in ("up", "down"):
                    self._walk(-1 if key == "up" else 1)
                elif key:
                    keys.append(key)
                i += len(seq)
                continue
            if ch in (b"\r", b"\n"):
                if ch == b"\n" and i and data[i - 1 : i] == b"\r":
                    i += 1
                    continue
                line = self.text.strip()
                self.text, self._at = "", None
                if line:
                    lines.append(line)
                    if not self.history or self.history[-1] != line:
                        self.history = (self.history + [line])[-self._limit :]
            elif ch in (b"\x7f", b"\x08"):
                self.text = self.text[:-1]
            elif ch == b"\x15":  # Ctrl-U
                self.text = ""
            elif 0x20 <= ch[0] <= 0x7E:
                self.text += ch.decode("ascii")
            i += 1
        return lines, keys

    @staticmethod
    def _sequence(data: bytes) -> Optional[bytes]:
        """The escape sequence at the start of ``data``: b"\\x1b" alone when
        another Esc or a plain key follows, None when it may be incomplete."""
        if len(data) == 1:
            return None
        if data[1:2] not in (b"[", b"O"):
            return b"\x1b"
        for j in range(2, min(len(data), 8)):
            if 0x40 <= data[j] <= 0x7E:
                return data[: j + 1]
        return None if len(data) < 8 else b"\x1b"

    def _walk(self, step: int) -> None:
        if not self.history:
            return
        at = len(self.history) if self._at is None else self._at
        at = min(max(at + step, 0), len(self.history))
        self._at = at
        self.text = self.history[at] if at < len(self.history) else ""


def stdin_is_terminal() -> bool:
    try:
        return sys.stdin is not None and sys.stdin.isatty()
    except (AttributeError, ValueError):
        return False
