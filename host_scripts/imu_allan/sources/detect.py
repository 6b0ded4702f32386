"""What ``imu-allan analyze`` reads, chosen by content (docs/formats.md).

* a device capture: any bytes holding intact protocol records (``$...*CRC``
  lines) or binary frames: the log of ``imu-allan sim`` or ``monitor``. Its
  complete reports (the on-device octave results) and, in modes raw, binary
  and both, its samples are decoded in one pass (device/capture.py; nothing
  unchecked is used).
* a rows file (thesis format): 7 integer codes per line (rows.py).
* delimited text with a header line naming the columns (table.py): CSV, TSV,
  EuRoC ``imu0/data.csv``, Kalibr's IMU CSV, ``rostopic echo -p`` output,
  one column named by its unit.
* ROS 1 bags, ROS 2 bags (a folder with metadata.yaml, a ``.db3`` or an
  ``.mcap``): sensor_msgs/Imu messages (rosbag.py).
* NumPy ``.npy`` and ``.npz`` arrays (arrays.py).
Anything else is refused with one line saying what was found.

Samples come as blocks (channels, samples): uint16 codes or float64 values,
read in blocks of a few MB, never the whole file at once.
"""

from __future__ import annotations

import os
import re
from typing import Any, Iterator, Optional

from ..channels import CHANNELS
from ..device.capture import Capture, read_capture
from ..device.files import input_name, read_blocks
from ..device.framing import split_frames
from ..device.records import DeviceReport
from ..device.stream import LOSS_KEYS, StreamDecoder
from ..errors import InputError, quote
from .rows import iter_blocks
from .source import TEMP_NOTE, SampleSource, Source
from .timing import FS_AGREE

SNIFF_BYTES = 1 << 16


_MAGIC = (
    (b"#ROSBAG V2.0", "rosbag"),
    (b"SQLite format 3\x00", "rosbag"),
    (b"\x89MCAP", "rosbag"),
    (b"\x93NUMPY", "npy"),
    (b"PK\x03\x04", "npz"),
)
"""How binary inputs begin: ROS 1 bag, ROS 2 storage (sqlite3, mcap), .npy, .npz."""


def load(path: str, topic: Optional[str] = None) -> Source:
    """Look at ``path`` and return what it holds (InputError with one line otherwise).

    A device capture is decoded in the same pass as the look at its first
    block and kept in memory; every other input is read lazily, block by
    block, when the statistics ask (stdin's text is kept in a temporary file).
    ``topic``: the bag topic to read when a bag holds several IMU topics.
    """
    name = input_name(path)
    if path != "-" and os.path.isdir(path):
        if os.path.isfile(os.path.join(path, "metadata.yaml")):
            from .rosbag import bag_source

            return Source(name, bag_source(path, name, topic), None)
        raise InputError(f"'{name}' is a folder without metadata.yaml: not a ROS 2 bag")
    blocks = read_blocks(path)
    first = next(blocks, b"")
    if not first:
        raise InputError(f"'{name}' is empty")
    head = first[:SNIFF_BYTES]
    kind = next((k for magic, k in _MAGIC if head.startswith(magic)), None)
    if kind is not None and path != "-":
        blocks.close()
        return Source(name, _binary(path, name, kind, topic), None)
    if is_capture(head):
        return _capture(name, read_capture(path, first, blocks))
    if kind is not None:
        raise InputError(f"'{name}': a {kind} file is read from a path, not from stdin")
    if path == "-":
        path = _spool(first, blocks)
        size = os.path.getsize(path)
    else:
        blocks.close()
        size = os.path.getsize(path)
    return _text(path, name, head, size)


def _binary(path: str, name: str, kind: str, topic: Optional[str]) -> SampleSource:
    if kind == "rosbag":
        from .rosbag import bag_source

        return bag_source(path, name, topic)
    from .arrays import array_source

    return array_source(path, name)


def check_options(src: Source, fs: Optional[float], scales: dict[str, Any]) -> None:
    """Options that contradict the file are errors: a ``--scale`` for a channel
    it does not have, an ``--fs`` its time column or stamps contradict."""
    samples = src.samples
    if samples is None:
        return
    missing = [ch for ch in scales if ch not in samples.channels]
    if missing:
        raise InputError(
            f"'{src.name}': --scale {missing[0]}=...: the file has no channel {missing[0]} "
            f"(its channels: {' '.join(samples.channels)})"
        )
    if fs is not None and samples.fs and samples.kind != "capture" and abs(fs - samples.fs) > FS_AGREE * samples.fs:
        what = "its header stamps" if samples.kind == "rosbag" else "its time column"
        raise InputError(
            f"'{src.name}': --fs {fs:g} contradicts {what} ({samples.fs:.6g} Hz); leave --fs out to use the stamps"
        )


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


def _first_line(head: bytes) -> tuple[int, str, str]:
    """The first line holding data (its number and text), and the comment line
    just before it (EuRoC's header is one: ``#timestamp [ns],w_RS_S_x ...``)."""
    comment = ""
    for i, raw in enumerate(head.split(b"\n")):
        parts = raw.split(b"#", 1)
        line = parts[0].strip()
        try:
            if line:
                return i + 1, line.decode("utf-8"), comment
            comment = parts[1].strip().decode("utf-8") if len(parts) > 1 else comment
        except UnicodeDecodeError:
            raise InputError("not text, not a device capture") from None
    return 0, "", comment


def _text(path: str, name: str, head: bytes, size: int) -> Source:
    from .table import csv_source, parse_header

    if b"\x00" in head:
        raise InputError(
            f"'{name}' is binary data: not a device capture (no intact records or frames), a rows or CSV "
            "file, a ROS bag or a NumPy array"
        )
    try:
        lineno, line, comment = _first_line(head)
    except InputError:
        raise InputError(f"'{name}' is neither a device capture (no intact records or frames) nor text") from None
    if not line:
        raise InputError(f"'{name}' holds no data (only comments or blank lines)")
    if re.search(r"[A-Za-z_]", line):
        return Source(name, csv_source(path, name, line, lineno, size), None)
    fields = line.replace(",", " ").replace(";", " ").split()
    if comment and parse_header(comment).chan_col and len(parse_header(comment).cols) == len(fields):
        return Source(name, csv_source(path, name, comment, lineno - 1, size), None)  # a header as a comment
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
                notes=[TEMP_NOTE],
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
