"""CSV and other delimited text with a header line naming the columns.

The header names the channels (ax ay az gx gy gz, and the names other tools
write: acc_x, gyro_x, ``field.angular_velocity.x`` of ``rostopic echo -p``,
EuRoC's ``w_RS_S_x``/``a_RS_S_x``, Kalibr's ``omega_x``/``alpha_x`` ...), an
optional time column (t, time, timestamp, ``%time``, ``field.header.stamp``,
``*_ns`` ...; a header stamp is preferred to a receive time) and units in
brackets (``gx [rad/s]``, ``ax (g)``, ``[rad s^-1]``). Fields that
sensor_msgs/Imu defines (and the formats that feed it: EuRoC, Kalibr's CSV)
carry their units by definition: rad/s and m/s^2. Every column not used is
named in a note. Separators: , ; tab or blanks.

Rows are parsed a few MB at a time by the compiled reader beside the Allan
kernels (stats/ck_text.c) when each line is plainly a row of numbers, else by
pandas' C reader (bench/parsers.py measures them beside pyarrow.csv and
numpy); the two give the same values. A bad row is parsed again by
numpy.loadtxt only to name its line.
"""

from __future__ import annotations

import functools
import io
import math
import re
from dataclasses import dataclass, field
from typing import Any, Iterator, Optional

import numpy as np

from ..channels import CHANNELS
from ..device.files import BLOCK_BYTES, read_blocks
from ..errors import InputError, quote
from .timing import TimeCheck, rate_from_time

SNIFF_BYTES = 1 << 16


def _names(prefixes: tuple[str, ...], axis: str) -> tuple[str, ...]:
    return tuple(p.format(axis) for p in prefixes)


_ACC = (
    "a{}",
    "acc{}",
    "acc_{}",
    "accel_{}",
    "accel{}",
    "a_{}",
    "accelerometer_{}",
    "linear_acceleration_{}",
    "acceleration_{}",
    "{}acc",
    "{}_acc",
    "alpha_{}",
    "a_rs_s_{}",
    "accelerometer_m_s2_{}",
)
_GYRO = (
    "g{}",
    "gyr{}",
    "gyr_{}",
    "gyro_{}",
    "gyro{}",
    "g_{}",
    "w{}",
    "w_{}",
    "omega_{}",
    "angular_velocity_{}",
    "rate_{}",
    "{}gyro",
    "{}_gyro",
    "w_rs_s_{}",
    "gyro_rad_{}",
    "gyroscope_{}",
)
ALIASES = {f"a{x}": _names(_ACC, x) for x in "xyz"} | {f"g{x}": _names(_GYRO, x) for x in "xyz"}
"""Column names (normalized: lower case, runs of other characters as ``_``) per channel."""

DEFINED_UNITS = {
    "linear_acceleration_": "m/s^2",  # sensor_msgs/Imu (REP 103: SI units)
    "angular_velocity_": "rad/s",
    "a_rs_s_": "m/s^2",  # EuRoC imu0/data.csv
    "w_rs_s_": "rad/s",
    "alpha_": "m/s^2",  # Kalibr's IMU CSV, written into sensor_msgs/Imu as is
    "omega_": "rad/s",
    "accelerometer_m_s2_": "m/s^2",  # PX4's sensor_combined (ulog2csv): the unit in the field's name
    "gyro_rad_": "rad/s",
}
"""Names whose unit a format fixes by definition (used when the header names none)."""

# name: (seconds per unit or None to read it from the values, preference: lower wins)
_TIME: dict[str, tuple[Optional[float], int]] = {
    "header_stamp": (1e-9, 0),  # ROS: integer ns, the sensor's own stamp
    "stamp": (None, 1),
    "timestamp_ns": (1e-9, 1),
    "time_ns": (1e-9, 1),
    "timestamp_us": (1e-6, 1),
    "time_us": (1e-6, 1),
    "timestamp_ms": (1e-3, 1),
    "time_ms": (1e-3, 1),
    "time_s": (1.0, 1),
    "sec": (1.0, 1),
    "secs": (1.0, 1),
    "seconds": (1.0, 1),
    "timestamp": (None, 2),
    "t": (None, 2),
    "ts": (None, 2),
    "time": (None, 3),  # ``%time`` of rostopic echo -p: when the message was received
    "rosbagtimestamp": (1e-9, 3),
}
"""Time columns by name: the factor to seconds (None: from the values) and a
preference (a sensor's stamp over a receive time)."""
_UNITS = {"ns": 1e-9, "us": 1e-6, "µs": 1e-6, "ms": 1e-3, "s": 1.0}
_UNIT_IN_NAME = re.compile(r"[\[(]\s*([^\])]*?)\s*[\])]")


_AXIS_INDEX = re.compile(r"\[\s*([012])\s*\]\s*$")
"""An array index as the axis, as ulog2csv writes PX4's vectors: ``gyro_rad[0]`` is x."""
_TIME_WITH_UNIT = re.compile(r"^(t|ts|time|timestamp|stamp|time_stamp|sample_time)_(ns|us|ms|s)$")
"""``t_ms``, ``time_us``, ``timestamp_ns`` ...: a time column whose name gives its unit."""


def normalize(col: str) -> tuple[str, Optional[str]]:
    """A header field as (key, unit): ``'w_RS_S_x [rad s^-1]'`` -> ``('w_rs_s_x', 'rad/s')``;
    ``'gyro_rad[0]'`` -> ``('gyro_rad_x', None)``."""
    unit = None
    col = _AXIS_INDEX.sub(lambda m: "_" + "xyz"[int(m.group(1))], col)
    m = _UNIT_IN_NAME.search(col)
    if m:
        unit = re.sub(r"\s*\bs\^-1$", "/s", m.group(1))
        unit = re.sub(r"\s*\bs\^-2$", "/s^2", unit)
        unit = unit.replace(" ", "").replace("²", "^2").replace("°", "deg")
        col = _UNIT_IN_NAME.sub("", col)
    key = re.sub(r"[^a-z0-9]+", "_", col.strip().lower()).strip("_")
    key = re.sub(r"^(field_|imu_|data_)+", "", key)
    return key, unit


def split_header(line: str) -> tuple[Optional[str], list[str]]:
    """The separator (None: blanks) and the fields; blanks inside brackets do not split."""
    for d in (",", ";", "\t"):
        if d in line:  # a name in quotes (phyphox, spreadsheets) is the name
            return d, [_unquote(p.strip()) for p in line.split(d)]
    return None, re.findall(r"(?:[^\s\[(]|\s*\[[^\]]*\]|\s*\([^)]*\))+", line.strip())


def _unquote(field: str) -> str:
    return field[1:-1].strip() if len(field) >= 2 and field[0] == field[-1] == '"' else field


def channel_of(key: str) -> Optional[str]:
    for ch, names in ALIASES.items():
        if key in names or any(key.endswith("_" + a) for a in names if len(a) > 2):
            return ch
    return None


@dataclass
class Header:
    """What a header line says: which column is which channel, the time column, units."""

    delim: Optional[str]
    cols: list[str]
    chan_col: dict[str, int] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    time_col: Optional[int] = None
    time_factor: Optional[float] = None
    defined: list[str] = field(default_factory=list)  # channels whose unit the format defines

    @property
    def channels(self) -> list[str]:
        return [ch for ch in CHANNELS if ch in self.chan_col]

    def unused(self) -> list[str]:
        used = set(self.chan_col.values()) | ({self.time_col} if self.time_col is not None else set())
        return [c for i, c in enumerate(self.cols) if i not in used and c]


def parse_header(line: str) -> Header:
    delim, cols = split_header(line)
    h = Header(delim, cols)
    pref = 99
    for i, col in enumerate(cols):
        key, unit = normalize(col)
        ch = channel_of(key)
        if ch is not None:
            if ch not in h.chan_col:
                h.chan_col[ch] = i
                defined = next((u for p, u in DEFINED_UNITS.items() if key.startswith(p)), None)
                if unit:
                    h.units[ch] = unit
                elif defined:
                    h.units[ch] = defined
                    h.defined.append(ch)
            continue
        named = _TIME.get(key) or _time_with_unit(key)
        if named and named[1] < pref:
            h.time_col, (h.time_factor, pref) = i, named
            if unit in _UNITS:
                h.time_factor = _UNITS[unit]
    if len(cols) == 1 and not h.chan_col:
        _unit_only(h, cols[0])
    return h


def _time_with_unit(key: str) -> Optional[tuple[Optional[float], int]]:
    m = _TIME_WITH_UNIT.match(key)
    return (_UNITS[m.group(2)], 1) if m else None


def _unit_only(h: Header, col: str) -> None:
    """One column named by its unit only (``[deg/s]``, ``gyro (rad/s)``): a
    gyroscope or accelerometer by the unit; read as its x channel."""
    from ..profiles import UNIT_FACTORS

    key, unit = normalize(col if _UNIT_IN_NAME.search(col) else f"[{col}]")
    for kind, ch in (("gyro", "gx"), ("acc", "ax")):
        if unit in UNIT_FACTORS[kind] and (not key or key.startswith(kind[:3])):
            h.chan_col[ch], h.units[ch] = 0, unit


def unused_note(cols: list[str]) -> Optional[str]:
    """``columns not used: a, b, c* (9) ...``: runs of numbered or x/y/z
    columns are shown once with their count."""
    if not cols:
        return None
    groups: dict[str, int] = {}
    for c in cols:
        stem = re.sub(r"(\d+|[._]?[xyzw])$", "*", c)
        groups[stem] = groups.get(stem, 0) + 1
    shown = [s if n == 1 and not s.endswith("*") else f"{s} ({n})" for s, n in groups.items()]
    return f"column{'s' if len(cols) > 1 else ''} not used: {', '.join(shown)}"


def csv_source(path: str, name: str, line: str, lineno: int, size: int) -> Any:
    """The SampleSource of a delimited text file whose header is ``line`` (line ``lineno``)."""
    from .source import SampleSource

    h = parse_header(line)
    if not h.chan_col:
        raise InputError(
            f"'{name}': line {lineno}: no column named like a sensor channel in "
            f"{quote(line)} (expected ax ay az gx gy gz, acc_x, gyro_x, ...)"
        )
    use = [h.chan_col[ch] for ch in h.channels]
    src = SampleSource(
        "csv",
        name,
        h.channels,
        lambda: None,  # set below, once the time check exists
        integer=False,
        n_hint=max(size // max(len(line), 8), 1),
        size_bytes=size,
        units=dict(h.units),
    )
    if h.defined:
        src.notes.append(
            f"units of {' '.join(h.defined)} by the format's definition "
            "(sensor_msgs/Imu, EuRoC, Kalibr, PX4: rad/s and m/s^2)"
        )
    note = unused_note(h.unused())
    if note:
        src.notes.append(note)
    nf = len(h.cols)
    first = next(csv_blocks(path, name, lineno, h.delim, use, h.time_col, SNIFF_BYTES, nf), None)
    if first is None or not first[0].size:
        raise InputError(f"'{name}': line {lineno} is a header, and no data row follows it")
    vals, t = first
    src.integer = bool(np.all(vals == np.rint(vals))) and bool(np.all((vals >= 0) & (vals <= 1023))) and not h.units
    check: Optional[TimeCheck] = None
    t0 = t[0] if t is not None and t.size else 0  # times from the first: exact in float64
    if t is not None and t.size >= 3:
        check = rate_from_time(name, (t - t0).astype(np.float64), h.time_factor, origin=float(t0))
        src.fs, src.time = check.fs, check
        src.notes.append(check.note)

    def blocks() -> Iterator[np.ndarray]:
        if check is not None:
            check.start()
        for vals, t in csv_blocks(path, name, lineno, h.delim, use, h.time_col, nfields=nf):
            if check is not None:
                check.feed((t - t0).astype(np.float64))
            yield vals
        if check is not None:
            check.finish(src.notes)

    src.open_blocks = blocks
    return src


def csv_blocks(
    path: str,
    name: str,
    header_line: int,
    delim: Optional[str],
    use: list[int],
    time_col: Optional[int],
    max_bytes: Optional[int] = None,
    nfields: Optional[int] = None,
) -> Iterator[tuple[np.ndarray, Optional[np.ndarray]]]:
    """Blocks of ((channels, rows) float64, time or None) after the header line;
    ``max_bytes`` reads only the start."""
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
                yield parse_csv(body, name, line, delim, use, time_col, nfields)
            line += body.count(b"\n")
            if not chunk or (max_bytes is not None and total >= max_bytes):
                break
    finally:
        blocks.close()


def _then_end(blocks: Iterator[bytes]) -> Iterator[bytes]:
    """The blocks, then b"" for the end."""
    yield from blocks
    yield b""


def parse_csv(
    body: bytes,
    name: str,
    first_line: int,
    delim: Optional[str],
    cols: list[int],
    time_col: Optional[int] = None,
    nfields: Optional[int] = None,
) -> tuple[np.ndarray, Optional[np.ndarray]]:
    """Whole lines of text -> ((len(cols), rows) float64, the time column or None);
    an integer time column stays int64 (epoch ns do not fit a double's 53 bits).
    One line naming the row on error; with ``nfields`` (the header's), a row
    with more or fewer fields is one (its extra value would be dropped unseen,
    or its columns shifted)."""
    fast = _compiled(body, delim, cols, time_col)
    if fast is not None:  # every row has the same fields: the first says if they are the header's
        _check_fields(body[: body.find(b"\n", 0, 1 << 16) + 1 or len(body)], name, first_line, delim, nfields)
        return fast
    _check_fields(body, name, first_line, delim, nfields)
    import pandas as pd

    every = cols + ([time_col] if time_col is not None else [])
    try:
        df = pd.read_csv(
            io.BytesIO(body),
            sep=delim if delim is not None else r"\s+",
            header=None,
            usecols=every,
            comment="#",
            dtype={c: np.float64 for c in cols},
            engine="c",
            skip_blank_lines=True,
            **_exact_floats(),
        )
        a = df[cols].to_numpy(dtype=np.float64).T
        t = None if time_col is None else df[time_col].to_numpy()
        if t is not None and t.dtype.kind not in "iuf":
            raise ValueError("time column not numeric")
    except Exception:  # a malformed row: numpy names it
        both = _slow_parse(body, name, first_line, delim, every)
        a, t = both[: len(cols)], (both[len(cols)] if time_col is not None else None)
    if not np.all(np.isfinite(a)) or (t is not None and t.dtype.kind == "f" and not np.all(np.isfinite(t))):
        bad = _bad_line(body, delim, every)
        where = f"line {first_line + 1 + bad[0]}" if bad else f"after line {first_line}"
        raise InputError(f"'{name}': {where}: {bad[1] if bad else 'a value is not a finite number'}")
    return np.ascontiguousarray(a), t


def _compiled(
    body: bytes, delim: Optional[str], cols: list[int], time_col: Optional[int]
) -> Optional[tuple[np.ndarray, Optional[np.ndarray]]]:
    """``parse_csv`` by the compiled reader (stats/ck_text.c) when every line is
    plainly a row of numbers as pandas reads it (the same values: correctly
    rounded floats, an integer time column as int64); None otherwise (quotes,
    ragged rows, empty fields, words, no extension): pandas decides."""
    from ..stats.kernels import _C

    if _C is None or (delim is not None and len(delim.encode()) != 1):
        return None
    ncols = max(cols + ([time_col] if time_col is not None else [])) + 1
    which = np.full(ncols, -1, dtype=np.intc)
    which[cols] = np.arange(len(cols), dtype=np.intc)
    cap = body.count(b"\n") + (not body.endswith(b"\n"))
    out = np.empty((len(cols), cap))
    tint = np.empty(cap if time_col is not None else 0, dtype=np.int64)
    tflt = np.empty(tint.size)
    d = delim.encode()[0] if delim is not None else 0
    rows, tfloat = _C.parse_table(body, d, which, -1 if time_col is None else time_col, out, tint, tflt, cap)
    if rows <= 0 or not np.all(np.isfinite(out[:, :rows])):
        return None
    a = out if rows == cap else np.ascontiguousarray(out[:, :rows])
    if time_col is None:
        return a, None
    if tfloat and not np.all(np.isfinite(tflt[:rows])):
        return None
    return a, (tflt if tfloat else tint)[:rows].copy()


@functools.lru_cache(maxsize=1)
def _exact_floats() -> dict[str, str]:
    """pandas before 3 parses floats correctly rounded only when asked."""
    try:
        import pandas as pd
    except ImportError:
        return {}
    return {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}


def _slow_parse(body: bytes, name: str, first_line: int, delim: Optional[str], cols: list[int]) -> np.ndarray:
    try:
        a = np.loadtxt(io.BytesIO(body), delimiter=delim, usecols=cols, comments="#", ndmin=2, dtype=np.float64)
    except ValueError as exc:
        # numpy counts its rows from 0 or from 1 depending on the fault, and skips blank
        # and comment lines: the line is found here instead, by the same reading
        bad = _bad_line(body, delim, cols)
        where = f"line {first_line + 1 + bad[0]}" if bad else f"after line {first_line}"
        what = bad[1] if bad else str(exc).split(" at row")[0].split("\n")[0]
        raise InputError(f"'{name}': {where}: {what}") from None
    return a.T


def _bad_line(body: bytes, delim: Optional[str], cols: list[int]) -> Optional[tuple[int, str]]:
    """(index among the lines of ``body``, what is wrong) of its first row whose
    used fields are missing, not numbers or not finite; blank lines and ``#``
    comments skipped as the readers skip them."""
    for i, raw in enumerate(body.split(b"\n")):
        text = raw.split(b"#", 1)[0].decode("utf-8", "replace").strip()
        if not text:
            continue
        fields = [f.strip() for f in text.split(delim)] if delim is not None else text.split()
        if len(fields) <= max(cols):
            return i, f"{_fields(len(fields))}, column {max(cols) + 1} expected"
        for c in cols:
            try:
                v = float(fields[c].replace("_", " "))  # float() takes 1_0; the readers do not
            except ValueError:
                return i, f"could not convert string {fields[c]!r} to float64"
            if not math.isfinite(v):
                return i, f"{fields[c]!r} is not a finite number"
    return None


def _check_fields(body: bytes, name: str, first_line: int, delim: Optional[str], nfields: Optional[int]) -> None:
    """The error naming the first row of ``body`` whose number of fields is not
    the header's ``nfields`` (one more is allowed when it is empty: a trailing
    separator). Blank lines, ``#`` comments and lines with quotes (pandas
    reads those) are not counted; blank-separated text is not checked."""
    if nfields is None or delim is None or len(delim.encode()) != 1 or b'"' in body:
        return
    b = np.frombuffer(body, dtype=np.uint8)
    ends = np.flatnonzero(b == 10)
    if not body.endswith(b"\n"):
        ends = np.append(ends, b.size)
    starts = np.concatenate(([0], ends[:-1] + 1))
    hashes = np.flatnonzero(b == 35)
    if hashes.size:  # each line cut at its first '#'
        h = np.searchsorted(hashes, starts)
        ends = np.minimum(ends, np.where(h < hashes.size, hashes[np.minimum(h, hashes.size - 1)], b.size))
    sep = delim.encode()
    seps = np.flatnonzero(b == sep[0])
    count = np.searchsorted(seps, ends) - np.searchsorted(seps, starts)
    for i in np.flatnonzero(count != nfields - 1).tolist():  # few: blank lines, comments, faults
        line = body[starts[i] : ends[i]].strip()
        if not line or (count[i] == nfields and line.endswith(sep)):
            continue
        raise InputError(
            f"'{name}': line {first_line + 1 + i}: {_fields(int(count[i]) + 1)}, but the header names {nfields}"
        )


def _fields(k: int) -> str:
    return f"{k} field{'' if k == 1 else 's'}"
