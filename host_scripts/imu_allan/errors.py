"""The one exception the command line turns into a single-line message."""
from __future__ import annotations


class InputError(Exception):
    """Bad input or usage (missing file, malformed row, ...): exit code 2.

    The message is one line meant for a person; no traceback is shown.
    """
