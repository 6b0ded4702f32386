"""Lines fitted to a terminal's width without losing a character: the one
rule of the monitor's screen (render/screen.py).

A line longer than the width is wrapped at its last space that fits (at the
width itself when a word is longer than that); each continuation row starts
with two spaces, so that a wrapped line reads as one.  Nothing is cut."""

from __future__ import annotations

INDENT = "  "


def wrap(text: str, width: int) -> list[str]:
    """``text`` as rows of at most ``width`` characters (see the module)."""
    width = max(width, 1)
    indent = INDENT if width > 2 * len(INDENT) else ""
    rows: list[str] = []
    rest = text.rstrip()
    lead = 0  # characters of ``rest`` that are the continuation's indent
    while len(rest) > width:
        cut = rest.rfind(" ", lead + 1, width + 1)
        if cut <= lead or not rest[lead:cut].strip():
            cut = width  # no space to break at: break inside the word
        rows.append(rest[:cut].rstrip())
        rest = indent + rest[cut:].lstrip(" ")
        lead = len(indent)
    rows.append(rest)
    return rows


def wrap_all(lines: list[str], width: int) -> list[str]:
    return [row for text in lines for row in wrap(text, width)]


def last_rows(text: str, width: int) -> str:
    """The end of a line being typed, as much as fits before the cursor
    (``width`` - 1 characters, the cursor's column kept free)."""
    return text[-(width - 1) :] if len(text) >= width else text
