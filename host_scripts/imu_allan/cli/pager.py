"""Long text for a person at a terminal goes through a pager, as git does: the
first screen shows the start of it (analyze's answer table) and the rest is a
key away, where printing it would scroll the answer off the top.  Not a
terminal (a pipe, a file, a test), or text that fits the screen: printed as is.
The pager is $PAGER (``less`` when unset, with LESS=FRX: quit when it fits,
keep colours, leave the text on the screen); PAGER=cat turns it off."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

NOT_FOUND = 127
"""The shell's exit status for a command it cannot find: then the text is printed."""


def page(text: str) -> None:
    """``text`` to stdout, through the pager when stdout is a terminal it overflows."""
    out = sys.stdout
    rows = shutil.get_terminal_size().lines
    command = os.environ.get("PAGER", "less").strip()
    if not out.isatty() or text.count("\n") < rows - 1 or command in ("", "cat"):
        out.write(text)
        return
    out.flush()
    env = dict(os.environ)
    env.setdefault("LESS", "FRX")
    try:
        proc = subprocess.Popen(command, shell=True, stdin=subprocess.PIPE, env=env, text=True)
    except OSError:
        out.write(text)
        return
    assert proc.stdin is not None
    try:
        proc.stdin.write(text)
        proc.stdin.close()
    except BrokenPipeError:  # the reader quit before the end (q in less)
        pass
    while True:
        try:
            rc = proc.wait()
            break
        except KeyboardInterrupt:  # Ctrl-C is the pager's to handle
            continue
    if rc == NOT_FOUND:
        out.write(text)
