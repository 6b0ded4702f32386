"""The serial link to the board: open and lock a port, send one command and
read its reply, read what the port has without waiting.

``send_command`` writes one command line and waits for its reply among
whatever else the device sends (reports, raw rows and binary frames may all
be in flight at once: everything goes through ``stream.StreamDecoder``).
pyserial is imported only here.  The live view over a port is
render/screen.py; the ``monitor`` and ``cmd`` commands wire them (cli/).
"""

from __future__ import annotations

import errno as _errno
import os
import time
from typing import IO, Any, Optional

from ..errors import InputError
from .framing import crc16
from .stream import StreamDecoder

READ_TIMEOUT = 0.1
"""Seconds one read of the port waits (the view's refresh granularity)."""


class PortError(Exception):
    """The port failed after it was opened (device unplugged, ...)."""


def open_port(port: str, baud: int, timeout: float = READ_TIMEOUT) -> Any:
    """A pyserial port, 8N1, locked for this process alone (flock, which
    pyserial, picocom and minicom honour): a second imu-allan on the same
    port gets InputError "port busy" and the first one keeps it.  InputError
    (one line) if it cannot be opened."""
    try:
        import serial  # type: ignore[import-untyped]
    except ImportError:
        raise InputError("pyserial is not installed (pip install pyserial)") from None
    try:
        return serial.Serial(port, baud, timeout=timeout, exclusive=True)
    except (serial.SerialException, OSError, ValueError) as exc:
        errno = getattr(exc, "errno", None)
        if errno in (_errno.EAGAIN, _errno.EWOULDBLOCK, _errno.EBUSY):
            raise InputError(
                f"port busy: '{port}' is open in another program (imu-allan monitor, a terminal?); close it first"
            ) from None
        why = os.strerror(errno) if isinstance(errno, int) else str(exc)
        raise InputError(f"cannot open port '{port}': {why}") from None


def command_line(words: list[str]) -> bytes:
    """WORDS -> the bytes of one command line, ``text*XXXX`` CR: the text
    and its check, the CRC-16 of the text in 4 upper-case hex digits, the
    same CRC as the device's own lines (docs/protocol.md, "Commands"), so
    that a bit flipped on the way makes the device refuse the line
    (``error:5``) instead of running another command.  InputError if
    unsendable."""
    text = " ".join(words).strip()
    if not text:
        raise InputError("empty command")
    if not all(0x20 <= ord(ch) <= 0x7E for ch in text):
        raise InputError(f"a command is printable ASCII: {text!r}")
    if "*" in text:
        raise InputError(f"a command holds no '*' (it starts the line's check): {text!r}")
    raw = text.encode("ascii")
    return b"%s*%04X\r" % (raw, crc16(raw))


def send_command(ser: Any, line: bytes, timeout: float) -> Optional[str]:
    """Send ``line``; the body of the first intact reply within ``timeout``
    seconds (``ok ...`` or ``error:...``), or None.  Other traffic (reports,
    raw rows, binary frames, the device's echo of typed lines, garbage) is
    read and ignored.  A boot line before any reply means the device
    (re)started after the line was sent, e.g. because opening the port
    reset it, so the line never reached its command loop: it is sent again,
    once.  A multi-line reply (``ok help ...``) is returned whole, its lines
    joined by newlines."""
    import serial  # type: ignore[import-untyped]

    dec = StreamDecoder()
    resent = False
    try:
        ser.reset_input_buffer()  # a reply already waiting is not ours
        ser.write(line)
        ser.flush()
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:  # each read waits READ_TIMEOUT at most
            data = ser.read(4096)
            if data:
                chunk = dec.feed(data)
                if chunk.replies:
                    return _rest_of_reply(ser, dec, chunk.replies)
                if chunk.boots and not resent:
                    resent = True
                    ser.write(line)
                    ser.flush()
    except (serial.SerialException, OSError) as exc:
        raise PortError(str(exc)) from None
    return None


def _rest_of_reply(ser: Any, dec: StreamDecoder, replies: list[str]) -> str:
    """The further lines of a multi-line reply (``ok help <command>``, one
    per command): read while they keep coming."""
    if not replies[0].startswith("ok help "):
        return replies[0]
    lines = [r for r in replies if r.startswith("ok help ")]
    quiet_until = time.monotonic() + 0.3
    while time.monotonic() < quiet_until:
        data = ser.read(4096)
        if data:
            more = [r for r in dec.feed(data).replies if r.startswith("ok help ")]
            if more:
                lines += more
                quiet_until = time.monotonic() + 0.3
    return "\n".join(lines)


LOG_DIR = "imu-allan-logs"
"""Where the monitor's logs go unless told (relative to the current directory;
the repository's .gitignore ignores it)."""


def default_log_name() -> str:
    return time.strftime("imu-allan-%Y%m%d-%H%M%S.log")


def log_path(asked: Optional[str]) -> str:
    """The monitor's log file: ``asked`` as given, or a new file named by the
    time (``default_log_name``) in ``asked`` when that is a directory (or ends
    with a separator), or in ``LOG_DIR`` when nothing was asked.  The
    directory is made when missing (InputError if it cannot be)."""
    if asked and not asked.endswith(os.sep) and not os.path.isdir(asked):
        return asked
    directory = asked or LOG_DIR
    try:
        os.makedirs(directory, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot make the log directory '{directory}': {exc.strerror or exc}") from None
    return os.path.join(directory, default_log_name())


class PortReader:
    """Reads what the port has, without waiting.  Tells a lost port (the
    device unplugged, the simulator ended) from a read that another program
    on the same port won, which must not end the monitor."""

    LOST_EMPTY_READS = 200
    LOST_AFTER_S = 2.0

    def __init__(self, ser: Any, port: str) -> None:
        self.ser, self.port = ser, port
        self.fd = ser.fileno()
        self._empty = 0
        self._empty_since = 0.0

    def read(self) -> bytes:
        """The bytes waiting (maybe none); PortError when the port is gone."""
        try:
            data = os.read(self.fd, 65536)
        except BlockingIOError:  # another reader took them between select and read
            return b""
        except OSError as exc:
            raise PortError(os.strerror(exc.errno) if exc.errno else str(exc)) from None
        if data:
            self._empty = 0
            return data
        # Readable but nothing read: a hang-up, or a race with another reader.
        now = time.monotonic()
        if self._empty == 0:
            self._empty_since = now
        self._empty += 1
        if not os.path.exists(self.port) or (
            self._empty >= self.LOST_EMPTY_READS and now - self._empty_since >= self.LOST_AFTER_S
        ):
            raise PortError("the device hung up")
        if self._empty > 20:
            time.sleep(0.01)  # a hang-up makes select return at once: do not spin
        return b""


def log_write(log: IO[bytes], data: bytes, log_path: str) -> None:
    try:
        log.write(data)
        log.flush()
    except OSError as exc:
        raise PortError(f"cannot write '{log_path}': {exc.strerror or exc}") from None
