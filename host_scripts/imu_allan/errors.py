"""The one exception the command line turns into a single-line message."""

from __future__ import annotations


class InputError(Exception):
    """Bad input or usage (missing file, malformed row, ...): exit code 2.

    The message is one line meant for a person; no traceback is shown.
    """


QUOTE_MAX = 60
"""Characters of input a message quotes: a line of a hostile file may be megabytes."""


def quote(text: str, limit: int = QUOTE_MAX) -> str:
    """``repr(text)``, cut to ``limit`` characters with ``...`` and its length when longer."""
    if len(text) <= limit:
        return repr(text)
    return f"{text[:limit]!r}... ({len(text)} characters)"
