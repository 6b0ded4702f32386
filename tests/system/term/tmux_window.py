"""A real terminal emulator for the terminal tests: tmux, with a server of
our own (-L) and one window running a command.  Keys are typed with
send-keys; what is on the screen, and what went into the scrollback, is read
with capture-pane.  Shared by the monitor's and analyze's terminal tests."""

from __future__ import annotations

import os
import subprocess
import time
from pathlib import Path
from typing import Callable


class Tmux:
    """One tmux server of our own (-L) with one window running a command."""

    def __init__(self, tmp: Path, command: str, width: int = 80, height: int = 24) -> None:
        self.socket = f"imu-allan-test-{os.getpid()}-{id(self)}"
        self.run("-f", "/dev/null", "new-session", "-d", "-s", "t", "-x", str(width), "-y", str(height), command)
        self.run("set-option", "-t", "t", "remain-on-exit", "on")

    def run(self, *args: str) -> str:
        return subprocess.run(["tmux", "-L", self.socket, *args], capture_output=True, text=True, check=True).stdout

    def keys(self, *keys: str) -> None:
        self.run("send-keys", "-t", "t", *keys)

    def screen(self) -> list[str]:
        return self.run("capture-pane", "-p", "-t", "t").split("\n")[:-1]

    def everything(self) -> str:
        """The scrollback and the screen."""
        return self.run("capture-pane", "-p", "-S", "-", "-t", "t")

    def value(self, name: str) -> str:
        return self.run("display-message", "-p", "-t", "t", f"#{{{name}}}").strip()

    def wait(self, ok: Callable[[list[str]], bool], what: str, timeout: float = 20.0) -> list[str]:
        deadline = time.monotonic() + timeout
        while True:
            lines = self.screen()
            if ok(lines):
                return lines
            if time.monotonic() > deadline:
                raise AssertionError(f"not on the screen after {timeout} s: {what}\n" + "\n".join(lines))
            time.sleep(0.1)

    def kill(self) -> None:
        subprocess.run(["tmux", "-L", self.socket, "kill-server"], capture_output=True)
