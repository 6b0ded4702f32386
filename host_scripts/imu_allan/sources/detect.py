"""What ``imu-allan analyze`` reads, chosen by content.

* a device capture: any bytes holding intact protocol records (``$...*CRC``
  lines) or binary frames: the log of ``imu-allan sim`` or ``monitor``. Its
  complete reports (the on-device octave results) and, in modes raw, binary
  and both, its samples are decoded in one pass (device/capture.py; nothing
  unchecked is used).
* a rows file (thesis format): 7 integer codes per line (rows.py).
* a CSV with a header line naming the columns: ax ay az gx gy gz (also
  acc_x, accel_x, gyro_x, gyr_x, wx, linear_acceleration_x, angular_velocity_x ...),
  an optional time column (t, time, timestamp, time_s, *_ns, *_us, *_ms)
  and units in brackets (``gx [rad/s]``, ``ax (g)``), separated by , ; tab
  or spaces.
Anything else is refused with one line saying what was found.

Samples come as blocks (channels, samples): uint16 codes or float64 values,
read in blocks of a few MB, never the whole file at once.
"""

from __future__ import annotations

import io
import math
import os
import re
from dataclasses import dataclass, field
from typing import Any, Callable, Iterator, Optional

import numpy as np

from ..channels import CHANNELS
from ..device.capture import Capture, read_capture
from ..device.files import BLOCK_BYTES, input_name, read_blocks
from ..device.framing import split_frames
from ..device.records import DeviceHeader, DeviceReport
from ..device.stream import LOSS_KEYS, StreamDecoder
from ..errors import InputError, quote
from .rows import iter_blocks

SNIFF_BYTES = 1 << 16


@dataclass
class SampleSource:
    kind: str  # "rows", "csv" or "capture"
    name: str
    channels: list[str]  # subset of CHANNELS, in file order of CHANNELS
    open_blocks: Callable[[], Iterator[np.ndarray]]
    integer: bool  # ADC codes
    fs: Optional[float] = None  # from a time column or a device header
    n_hint: Optional[int] = None  # expected samples (progress bars), may be None
    size_bytes: Optional[int] = None
    units: dict[str, str] = field(default_factory=dict)  # from the CSV header
    notes: list[str] = field(default_factory=list)
    open_temperature: Optional[Callable[[], Iterator[np.ndarray]]] = None
    """Blocks of the temperature column's codes, aligned with ``open_blocks``
    (rows files and captures carry it; CSV does not)."""


@dataclass
class Source:
    name: str
    samples: Optional[SampleSource]
    report: Optional[DeviceReport]  # last complete device report
    complete_reports: int = 0
    errors: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def header(self) -> Optional[DeviceHeader]:
        return self.report.header if self.report is not None else None


def load(path: str) -> Source:
    """Look at ``path`` and return what it holds (InputError with one line otherwise).

    A device capture is decoded in the same pass as the look at its first
    block and kept in memory; rows files and CSV are read lazily, block by
    block, when the statistics ask (stdin's text is kept in a temporary file).
    """
    name = input_name(path)
    blocks = read_blocks(path)
    first = next(blocks, b"")
    if not first:
        raise InputError(f"'{name}' is empty")
    head = first[:SNIFF_BYTES]
    if is_capture(head):
        return _capture(name, read_capture(path, first, blocks))
    if path == "-":
        path = _spool(first, blocks)
        size = os.path.getsize(path)
    else:
        blocks.close()
        size = os.path.getsize(path)
    return _text(path, name, head, size)


def load_device_report(path: str) -> DeviceReport:
    """The last complete device report of ``path`` (``analyze --device``)."""
    src = load(path)
    if src.report is None:
        raise InputError(f"--device '{path}': no complete device report in it")
    return src.report


def _spool(first: bytes, rest: Iterator[bytes]) -> str:
    """Text from stdin into a temporary file (read again lazily; removed at exit)."""
    import atexit
    import tempfile

    tmp = tempfile.NamedTemporaryFile(prefix="imu-allan-", suffix=".in", delete=False)
    with tmp:
        tmp.write(first)
        for block in rest:
            tmp.write(block)
    atexit.register(_unlink, tmp.name)
    return tmp.name


def _unlink(path: str) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


# ---- device captures ---------------------------------------------------------------

CAPTURE_BLOCK = 1 << 20
"""Samples handed to the statistics at a time from a capture in memory."""


def _one_setting(name: str, cap: Capture) -> None:
    """Samples taken at two rates or ranges are not one series: refuse them
    (the headers, and replies such as ``ok reset rate=250`` or ``ok status
    ... fs=100 range=1.5``, say what the device was set to, in order)."""
    rates: list[float] = []
    ranges: list[str] = []
    said = [("H", r.header.fs_hz, r.header.range_g) for r in cap.reports]
    for body in cap.replies:
        words = dict(w.split("=", 1) for w in body.split()[1:] if "=" in w)
        said.append(("ok", words.get("rate", words.get("fs")), words.get("range")))
    for _, rate, rng in said:
        try:
            if rate is not None and float(rate) not in rates:
                rates.append(float(rate))
        except ValueError:
            pass
        if rng is not None and rng not in ranges:
            ranges.append(rng)
    if len(rates) > 1:
        raise InputError(
            f"'{name}': the sample rate changes midway ({', then '.join(f'{r:g}' for r in rates)}"
            " Hz): its samples are not one series; cut the capture at the change and "
            "analyze each part at its own rate"
        )
    if len(ranges) > 1:
        raise InputError(
            f"'{name}': the accelerometer range changes midway ({', then '.join(ranges)} g): "
            "cut the capture at the change and analyze each part"
        )


def is_capture(head: bytes) -> bool:
    """Intact protocol lines or binary frames in the first bytes."""
    if split_frames(head).bodies:
        return True
    dec = StreamDecoder(line_start=True)
    dec.feed(head)
    return dec.counts["frames"] > 0


def _capture(name: str, cap: Capture) -> Source:
    c = dict(cap.counts)
    reports = cap.reports
    src = Source(name, None, reports[-1] if reports else None, len(reports), c)
    lost = {k: c[k] for k in LOSS_KEYS if c.get(k)}
    n = cap.samples.shape[1]
    if n >= 2:
        _one_setting(name, cap)
        codes = cap.samples[: len(CHANNELS)]
        samples = SampleSource(
            "capture",
            name,
            list(CHANNELS),
            lambda: (codes[:, a : a + CAPTURE_BLOCK] for a in range(0, n, CAPTURE_BLOCK)),
            True,
            n_hint=n,
            size_bytes=None,
        )
        temp = cap.samples[len(CHANNELS)]
        samples.open_temperature = lambda: (temp[a : a + CAPTURE_BLOCK] for a in range(0, n, CAPTURE_BLOCK))
        if src.header is not None:
            samples.fs = float(src.header.fs_hz)
        if lost:
            samples.notes.append(
                "samples were lost or damaged on the way ("
                + ", ".join(f"{k} {v}" for k, v in lost.items())
                + "): the series has gaps, which the host statistics ignore"
            )
        src.samples = samples
    if src.report is None and src.samples is None:
        bad = ", ".join(f"{k} {v}" for k, v in c.items() if v) or "nothing usable"
        raise InputError(f"'{name}': a device capture without a complete report or samples ({bad})")
    return src


# ---- text: rows files and CSV ---------------------------------------------------------


def _first_line(head: bytes) -> tuple[int, str]:
    for i, raw in enumerate(head.split(b"\n")):
        line = raw.split(b"#", 1)[0].strip()
        if line:
            try:
                return i + 1, line.decode("utf-8")
            except UnicodeDecodeError:
                raise InputError("not text, not a device capture") from None
    return 0, ""


def _text(path: str, name: str, head: bytes, size: int) -> Source:
    if b"\x00" in head:
        raise InputError(
            f"'{name}' is binary data, neither a device capture (no intact records or frames) nor a rows or CSV file"
        )
    try:
        lineno, line = _first_line(head)
    except InputError:
        raise InputError(f"'{name}' is neither a device capture (no intact records or frames) nor text") from None
    if not line:
        raise InputError(f"'{name}' holds no data (only comments or blank lines)")
    if re.search(r"[A-Za-z_]", line):
        return Source(name, _csv(path, name, line, lineno, head, size), None)
    fields = line.replace(",", " ").replace(";", " ").split()
    if len(fields) == 7 and all(re.fullmatch(r"\d+", f) for f in fields):
        return Source(
            name,
            SampleSource(
                "rows",
                name,
                list(CHANNELS),
                lambda: (b[: len(CHANNELS)] for b in iter_blocks(path, name=name)),
                True,
                n_hint=max(size // 26, 1),
                size_bytes=size,
                open_temperature=lambda: (b[len(CHANNELS)] for b in iter_blocks(path, name=name)),
            ),
            None,
        )
    if len(fields) == 7 and all(re.fullmatch(r"[-+]?\d+(\.\d*)?", f) for f in fields):
        bad = next(f for f in fields if not re.fullmatch(r"\d+", f))
        raise InputError(
            f"'{name}': line {lineno}: {quote(bad)} is not a 10-bit ADC code (a rows file "
            "has 7 integer codes 0..1023: ax ay az gx gy gz temp)"
        )
    raise InputError(
        f"'{name}': line {lineno} has {len(fields)} numeric columns and no header: "
        "a rows file has 7 integer codes (ax ay az gx gy gz temp); for other data "
        "add a first line naming the columns, e.g. 't,ax,ay,az,gx,gy,gz'"
    )


_ALIASES = {
    "ax": (
        "ax",
        "accx",
        "acc_x",
        "accel_x",
        "accelx",
        "a_x",
        "accelerometer_x",
        "linear_acceleration_x",
        "acceleration_x",
        "xacc",
        "x_acc",
    ),
    "ay": (
        "ay",
        "accy",
        "acc_y",
        "accel_y",
        "accely",
        "a_y",
        "accelerometer_y",
        "linear_acceleration_y",
        "acceleration_y",
        "yacc",
        "y_acc",
    ),
    "az": (
        "az",
        "accz",
        "acc_z",
        "accel_z",
        "accelz",
        "a_z",
        "accelerometer_z",
        "linear_acceleration_z",
        "acceleration_z",
        "zacc",
        "z_acc",
    ),
    "gx": (
        "gx",
        "gyrx",
        "gyr_x",
        "gyro_x",
        "gyrox",
        "g_x",
        "wx",
        "w_x",
        "omega_x",
        "angular_velocity_x",
        "rate_x",
        "xgyro",
        "x_gyro",
    ),
    "gy": (
        "gy",
        "gyry",
        "gyr_y",
        "gyro_y",
        "gyroy",
        "g_y",
        "wy",
        "w_y",
        "omega_y",
        "angular_velocity_y",
        "rate_y",
        "ygyro",
        "y_gyro",
    ),
    "gz": (
        "gz",
        "gyrz",
        "gyr_z",
        "gyro_z",
        "gyroz",
        "g_z",
        "wz",
        "w_z",
        "omega_z",
        "angular_velocity_z",
        "rate_z",
        "zgyro",
        "z_gyro",
    ),
}
_TIME: dict[str, Optional[float]] = {
    "t": None,
    "time": None,
    "timestamp": None,
    "stamp": None,
    "ts": None,  # unit from magnitude
    "time_s": 1.0,
    "sec": 1.0,
    "secs": 1.0,
    "seconds": 1.0,
    "time_ns": 1e-9,
    "timestamp_ns": 1e-9,
    "time_us": 1e-6,
    "timestamp_us": 1e-6,
    "time_ms": 1e-3,
    "timestamp_ms": 1e-3,
    "field_header_stamp": 1e-9,
    "header_stamp": 1e-9,
    "rosbagtimestamp": 1e-9,
}  # ROS: integer ns
"""Time columns by name, and the factor to seconds (None: read from the values)."""
FS_RANGE = (0.1, 100e3)
"""Sample rates a time column may give, Hz; outside, its unit was misread."""
_UNITS = {"ns": 1e-9, "us": 1e-6, "µs": 1e-6, "ms": 1e-3, "s": 1.0}


def time_unit(t: np.ndarray, step: float) -> float:
    """Seconds per unit of a time column named without a unit (``%time`` of
    ``rostopic echo -p`` is integer ns): epoch values tell by their size
    (~1.7e18 ns, 1.7e15 us, 1.7e12 ms, 1.7e9 s); times from 0 by the step,
    the first unit in s, ms, us, ns that gives 1 Hz .. 10 kHz."""
    t0 = float(abs(t[0])) if t.size else 0.0
    for size, factor in ((1e17, 1e-9), (1e14, 1e-6), (1e11, 1e-3)):
        if t0 >= size:
            return factor
    if t0 < 1e8 and step > 0:
        for factor in (1.0, 1e-3, 1e-6, 1e-9):
            if 1.0 <= 1.0 / (step * factor) <= 1e4:
                return factor
    return 1.0


_UNIT_IN_NAME = re.compile(r"[\[(]\s*([^\])]*?)\s*[\])]")


def _normalize(col: str) -> tuple[str, Optional[str]]:
    unit = None
    m = _UNIT_IN_NAME.search(col)
    if m:
        unit = m.group(1).replace(" ", "").replace("²", "^2").replace("°", "deg")
        col = _UNIT_IN_NAME.sub("", col)
    key = re.sub(r"[^a-z0-9]+", "_", col.strip().lower()).strip("_")
    key = re.sub(r"^(field_|imu_|data_)+", "", key)
    return key, unit


def _split(line: str) -> tuple[Optional[str], list[str]]:
    for d in (",", ";", "\t"):
        if d in line:
            return d, [p.strip() for p in line.split(d)]
    return None, line.split()


def _csv(path: str, name: str, header: str, lineno: int, head: bytes, size: int) -> SampleSource:
    delim, cols = _split(header)
    chan_col: dict[str, int] = {}
    units: dict[str, str] = {}
    time_col, time_factor = None, None
    for i, col in enumerate(cols):
        key, unit = _normalize(col)
        for ch, names in _ALIASES.items():
            if key in names or any(key.endswith("_" + a) for a in names if len(a) > 2):
                if ch not in chan_col:
                    chan_col[ch] = i
                    if unit:
                        units[ch] = unit
                break
        else:
            if key in _TIME and time_col is None:
                time_col, time_factor = i, _TIME[key]
                if unit in _UNITS:
                    time_factor = _UNITS[unit]
    if not chan_col:
        raise InputError(
            f"'{name}': line {lineno}: no column named like a sensor channel in "
            f"{quote(header)} (expected ax ay az gx gy gz, acc_x, gyro_x, ...)"
        )
    chans = [ch for ch in CHANNELS if ch in chan_col]
    use = [chan_col[ch] for ch in chans]
    src = SampleSource(
        "csv",
        name,
        chans,
        lambda: _csv_blocks(path, name, lineno, delim, use, time_col, len(cols)),
        integer=False,
        n_hint=max(size // max(len(header), 8), 1),
        size_bytes=size,
        units=units,
    )
    # first rows: are the values integer codes? a time column gives fs
    first = next(
        _csv_blocks(path, name, lineno, delim, use, time_col, len(cols), max_bytes=SNIFF_BYTES, with_time=True), None
    )
    if first is None or not first[0].size:
        raise InputError(f"'{name}': line {lineno} is a header, and no data row follows it")
    if first is not None:
        vals, t = first
        src.integer = (
            bool(vals.size) and bool(np.all(vals == np.rint(vals))) and bool(np.all((vals >= 0) & (vals <= 1023)))
        )
        if t is not None and t.size >= 3:
            _rate_from_time(src, name, t, time_factor)
    return src


def _rate_from_time(src: SampleSource, name: str, t: np.ndarray, factor: Optional[float]) -> None:
    steps = np.diff(t)
    steps = steps[np.isfinite(steps)]
    raw = float(np.median(steps)) if steps.size else math.nan
    if not (raw > 0 and math.isfinite(raw)):
        return
    how = "named" if factor is not None else "read from the values"
    factor = time_unit(t, raw) if factor is None else factor
    med = raw * factor
    fs = 1.0 / med
    span = float(t[-1] - t[0]) * factor
    if span > 0 and np.all(np.abs(steps * factor - med) <= 0.01 * med):
        fs = (t.size - 1) / span  # regular steps: the span, not one step, sets the rate
        # (epoch ns in float64 are quantized to 256 ns: one step is that coarse, the span is not)
    if not FS_RANGE[0] <= fs <= FS_RANGE[1]:
        raise InputError(
            f"'{name}': the time column gives {fs:.6g} Hz (median step {med:.6g} s, unit "
            f"{how}), outside {FS_RANGE[0]:g} Hz .. {FS_RANGE[1]:g} Hz: give its unit in the "
            "header (e.g. 'time [ns]') or --fs"
        )
    src.fs = fs
    jitter = float(np.max(np.abs(steps * factor - med)) / med)
    unit = {1e-9: "ns", 1e-6: "us", 1e-3: "ms", 1.0: "s"}.get(factor, f"{factor:g} s")
    src.notes.append(
        f"sample rate {fs:.6g} Hz from the time column (in {unit}, {how}; median step "
        f"{med:.6g} s" + (f", steps vary by up to {jitter * 100:.0f} %, more than 1 %" if jitter > 0.01 else "") + ")"
    )


def _csv_blocks(
    path: str,
    name: str,
    header_line: int,
    delim: Optional[str],
    use: list[int],
    time_col: Optional[int],
    ncols: int,
    max_bytes: Optional[int] = None,
    with_time: bool = False,
) -> Iterator[Any]:
    """Blocks of (channels, rows) float64 after the header line (with the time
    column as a second item when ``with_time``); ``max_bytes`` reads only the start."""
    cols = use + ([time_col] if with_time and time_col is not None else [])
    line, tail, total, skip = header_line, b"", 0, header_line
    blocks = read_blocks(path, BLOCK_BYTES if max_bytes is None else max_bytes)
    try:
        for chunk in _then_end(blocks):
            total += len(chunk)
            data = tail + chunk
            while skip and data:  # the lines up to the header's
                nl = data.find(b"\n")
                if nl < 0:
                    break
                data, skip = data[nl + 1 :], skip - 1
            if skip and chunk:
                tail = data
                continue
            cut = data.rfind(b"\n") + 1 if chunk else len(data)
            body, tail = data[:cut], data[cut:]
            if body.strip():
                arr = _parse_csv(body, name, line, delim, cols)
                if with_time:
                    yield (arr[: len(use)], arr[len(use)] if time_col is not None else None)
                else:
                    yield arr
            line += body.count(b"\n")
            if not chunk or (max_bytes is not None and total >= max_bytes):
                break
    finally:
        blocks.close()


def _then_end(blocks: Iterator[bytes]) -> Iterator[bytes]:
    """The blocks, then b"" for the end."""
    yield from blocks
    yield b""


def _parse_csv(body: bytes, name: str, first_line: int, delim: Optional[str], cols: list[int]) -> np.ndarray:
    try:
        a = np.loadtxt(io.BytesIO(body), delimiter=delim, usecols=cols, comments="#", ndmin=2, dtype=np.float64)
    except ValueError as exc:
        msg = str(exc)
        m = re.search(r"at row (\d+)", msg)
        where = f"line {first_line + 1 + int(m.group(1))}" if m else f"after line {first_line}"
        what = msg.split(" at row")[0].split("\n")[0]
        raise InputError(f"'{name}': {where}: {what}") from None
    if not np.all(np.isfinite(a)):
        r = int(np.argmax(~np.all(np.isfinite(a), axis=1)))
        raise InputError(f"'{name}': line {first_line + 1 + r}: a value is not a finite number")
    return np.ascontiguousarray(a.T)
