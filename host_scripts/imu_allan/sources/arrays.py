"""NumPy arrays: ``.npy`` (one 2-D array) and ``.npz`` (named arrays).

The column convention (docs/formats.md):

* ``.npy`` of shape (n, 6) or (n, 7), one sample a row (an array with 6 or 7
  rows and more columns is read transposed):
  - integer dtype: ADC codes ``ax ay az gx gy gz [temp]``, as a rows file;
  - float dtype, 6 columns: ``ax ay az gx gy gz`` in m/s^2 and rad/s (SI, as
    sensor_msgs/Imu); 7 columns: ``t ax ay az gx gy gz``, t in seconds.
* ``.npz``: arrays named like CSV columns (``ax``, ``gyro_x``, ``t``, units in
  brackets: ``gx [deg/s]``), or ``acc``/``gyro`` of shape (n, 3) (x y z), and
  optional ``t`` in seconds; floats without a unit are SI, integers ADC codes.
  A structured ``.npy`` (named fields) reads like an ``.npz``.

A ``.npy`` is memory-mapped and handed out a block at a time; an ``.npz``
member is decompressed whole when read (zip members do not map).
"""

from __future__ import annotations

import zipfile
import zlib
from typing import Any, Callable, Iterator, Optional

import numpy as np

from ..channels import CHANNELS
from ..errors import InputError
from .table import channel_of, normalize, unused_note
from .timing import rate_from_time

BLOCK_ROWS = 1 << 18
_BROKEN = (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error)
"""What numpy and zipfile raise on a cut or damaged .npy / .npz (a bad CRC, a member cut short)."""
SI = {ch: ("rad/s" if ch[0] == "g" else "m/s^2") for ch in CHANNELS}


def array_source(path: str, name: str) -> Any:
    """The SampleSource of a .npy or .npz file."""
    try:
        if _is_zip(path):
            with np.load(path, allow_pickle=False) as z:
                members = {k: (z[k].shape, z[k].dtype) for k in z.files}
            return _named(name, members, lambda used: _npz_members(path, used))
        a = np.load(path, mmap_mode="r", allow_pickle=False)
    except _BROKEN as exc:
        raise InputError(f"'{name}': not a readable NumPy file ({exc})") from None
    if a.dtype.names:
        return _structured(path, name, a)
    return _plain(path, name, a)


def _is_zip(path: str) -> bool:
    with open(path, "rb") as f:
        return f.read(4) == b"PK\x03\x04"


def _plain(path: str, name: str, a: np.ndarray) -> Any:
    if a.ndim != 2 or 6 not in a.shape and 7 not in a.shape:
        raise InputError(
            f"'{name}': an array of shape {a.shape}: expected (n, 6) ax ay az gx gy gz, or (n, 7) with "
            "t first (floats) or temp last (integer codes)"
        )
    rows_major = a.shape[1] in (6, 7)
    ncol = a.shape[1] if rows_major else a.shape[0]
    integer = a.dtype.kind in "iu"
    if a.dtype.kind not in "iuf":
        raise InputError(f"'{name}': array of dtype {a.dtype}: expected integers (ADC codes) or floats")
    t_col = 0 if ncol == 7 and not integer else None
    first = 1 if t_col == 0 else 0
    n = a.shape[0] if rows_major else a.shape[1]

    def cols(lo: int, hi: int) -> np.ndarray:  # (ncol, rows) of rows lo..hi
        part = a[lo:hi] if rows_major else a[:, lo:hi].T
        return np.ascontiguousarray(np.asarray(part).T)

    def blocks() -> Iterator[np.ndarray]:
        for lo in range(0, n, BLOCK_ROWS):
            yield cols(lo, lo + BLOCK_ROWS)

    from .source import TEMP_NOTE, SampleSource

    pick = slice(first, first + len(CHANNELS))
    src = SampleSource("npy", name, list(CHANNELS), lambda: iter(()), integer, n_hint=n)
    if integer:
        src.open_blocks = lambda: (_codes(name, b[pick]) for b in blocks())
        if ncol == 7:
            src.open_temperature = lambda: (_codes(name, b[6]) for b in blocks())
            src.notes.append(TEMP_NOTE)
        src.notes.append("integer array: ADC codes ax ay az gx gy gz" + (" temp" if ncol == 7 else ""))
        return src
    src.units = dict(SI)
    src.notes.append(
        f"float array: columns {'t ' if t_col == 0 else ''}ax ay az gx gy gz, in m/s^2 and rad/s "
        "(the .npy convention; --scale CH=1UNIT for other units)"
    )
    _timed(src, name, lambda: ((b[pick], b[0] if t_col == 0 else None) for b in blocks()))
    return src


def _codes(name: str, b: np.ndarray) -> np.ndarray:
    if b.size and (b.min() < 0 or b.max() > 1023):
        raise InputError(f"'{name}': an integer array holds {int(b.min())}..{int(b.max())}: not 10-bit ADC codes")
    return b.astype(np.uint16)


def _timed(src: Any, name: str, open_pairs: Callable[[], Iterator[tuple[np.ndarray, Optional[np.ndarray]]]]) -> None:
    """``open_blocks`` from (values, time) blocks; the rate and gaps from the time."""
    first = next(open_pairs(), None)
    if first is None or not first[0].shape[1]:
        raise InputError(f"'{name}': no samples")
    check = None
    if first[1] is not None and first[1].size >= 3:
        check = rate_from_time(name, np.asarray(first[1][:4096], dtype=np.float64), 1.0, "its t column")
        src.fs, src.time = check.fs, check
        src.notes.append(check.note)

    def blocks() -> Iterator[np.ndarray]:
        if check is not None:
            check.start()
        for vals, t in open_pairs():
            vals = np.asarray(vals, dtype=np.float64)
            if not np.isfinite(vals).all():
                raise InputError(f"'{name}': a value is not a finite number")
            if check is not None and t is not None:
                check.feed(t)
            yield vals
        if check is not None:
            check.finish(src.notes)

    src.open_blocks = blocks


def _match(name: str, keys: list[str]) -> tuple[dict[str, tuple[str, int]], dict[str, str], Optional[str]]:
    """Channel -> (member, column), units by channel, and the time member."""
    found: dict[str, tuple[str, int]] = {}
    units: dict[str, str] = {}
    time = None
    for k in keys:
        key, unit = normalize(k)
        ch = channel_of(key)
        if ch is not None and ch not in found:
            found[ch] = (k, -1)
            if unit:
                units[ch] = unit
        elif key in ("acc", "accel", "accelerometer", "linear_acceleration", "gyro", "gyr", "angular_velocity"):
            kind = "a" if key.startswith(("acc", "lin")) else "g"
            for i, x in enumerate("xyz"):
                found.setdefault(kind + x, (k, i))
                if unit:
                    units.setdefault(kind + x, unit)
        elif key in ("t", "time", "time_s", "timestamp", "stamp") and time is None:
            time = k
    return found, units, time


def _npz_members(path: str, used: set[str]) -> dict[str, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as z:
            return {m: z[m] for m in used}
    except _BROKEN as exc:
        raise InputError(f"'{path}': not a readable NumPy file ({exc})") from None


def _named(
    name: str,
    members: dict[str, tuple[tuple[int, ...], Any]],
    load: Callable[[set[str]], dict[str, np.ndarray]],
) -> Any:
    from .source import SampleSource

    found, units, time = _match(name, list(members))
    if not found:
        raise InputError(
            f"'{name}': no array named like a channel (members: {', '.join(members) or 'none'}; expected ax .. gz, "
            "acc and gyro of shape (n, 3), t)"
        )
    chans = [ch for ch in CHANNELS if ch in found]
    used = {m for m, _ in found.values()} | ({time} if time else set())
    integer = all(np.dtype(members[found[c][0]][1]).kind in "iu" for c in chans) and not units
    n = members[found[chans[0]][0]][0][0]
    for c in chans:
        shape = members[found[c][0]][0]
        if shape[0] != n or (found[c][1] >= 0 and (len(shape) != 2 or shape[1] != 3)):
            raise InputError(f"'{name}': member {found[c][0]} has shape {shape}: not {n} samples (x y z columns)")

    def pairs() -> Iterator[tuple[np.ndarray, Optional[np.ndarray]]]:
        arrays = load(used)
        cols = [arrays[found[c][0]] if found[c][1] < 0 else arrays[found[c][0]][:, found[c][1]] for c in chans]
        for lo in range(0, n, BLOCK_ROWS):
            vals = np.vstack([c[lo : lo + BLOCK_ROWS] for c in cols])
            yield vals, (arrays[time][lo : lo + BLOCK_ROWS] if time else None)

    src = SampleSource("npy", name, chans, lambda: iter(()), integer, n_hint=int(n))
    note = unused_note([m for m in members if m not in used])
    if note:
        src.notes.append(note)
    if integer:
        src.open_blocks = lambda: (_codes(name, v) for v, _ in pairs())
        return src
    src.units = {ch: units.get(ch, SI[ch]) for ch in chans}
    if any(ch not in units for ch in chans):
        src.notes.append("arrays without a unit in their name read as SI (m/s^2, rad/s)")
    _timed(src, name, pairs)
    return src


def _structured(path: str, name: str, a: np.ndarray) -> Any:
    members = {k: ((a.shape[0],) + a.dtype[k].shape, a.dtype[k].base) for k in a.dtype.names}
    return _named(name, members, lambda used: {m: a[m] for m in used})
