"""``imu-allan monitor``: the loop that wires a port (device/link.py) to the
live view (render/screen.py) and to the log file."""

from __future__ import annotations

import sys
from typing import IO, Optional

from ..device.link import PortError
from ..errors import InputError


def run_monitor(
    port: str,
    baud: int,
    log_path: Optional[str],
    once: bool,
    out: Optional[IO[str]] = None,
    err: Optional[IO[str]] = None,
) -> int:
    """The monitor: a full-screen view when ``out`` (stdout by default) is a
    terminal, taking commands typed on stdin when that is a terminal too;
    plain lines otherwise.  Returns the exit status (0, or 1 when the port
    or the log fails)."""
    from ..device.link import log_path as resolve_log
    from ..device.link import open_port
    from ..render.screen import Monitor, run_plain, run_screen
    from ..render.terminal import stdin_is_terminal

    out = out or sys.stdout
    err = err or sys.stderr
    ser = open_port(port, baud)  # first: a port that cannot be opened leaves no log behind
    try:
        path = resolve_log(log_path)  # InputError if its directory cannot be made
        log = open(path, "ab")
    except OSError as exc:
        ser.close()
        raise InputError(f"cannot write '{path}': {exc.strerror or exc}") from None
    except InputError:
        ser.close()
        raise
    tty = out.isatty()
    mon = Monitor(port, baud, path, commands=tty and stdin_is_terminal())
    if not tty:
        print(f"imu-allan monitor: {port} at {baud} baud, logging to {path}", file=err)
    status = 0
    try:
        (run_screen if tty else run_plain)(ser, mon, log, out, once)
        if tty and once:  # the full screen is gone: leave what --once waited for
            out.write(mon.render())
    except PortError as exc:
        why = str(exc)
        print(
            f"imu-allan monitor: {port}: " + (why if why.startswith("cannot write") else f"connection lost ({why})"),
            file=err,
        )
        status = 1
    except KeyboardInterrupt:
        pass
    finally:
        ser.close()
        log.close()
    print(f"imu-allan monitor: {mon.reports} complete reports, {mon.stream_line()}; log {path}", file=err)
    return status
