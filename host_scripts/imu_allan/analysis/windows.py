"""The windows of a recording for the dynamic Allan variance (dynamic.py):
from a device log's successive reports or from a raw recording's samples,
read through sources; shared by `imu-allan dynamic` and analyze's warm-up test."""

from __future__ import annotations

import math
from typing import Any, Optional

import numpy as np

from ..errors import InputError
from .pipeline import _num as json_num  # the one JSON number rule of the documents

MEMORY = 1 << 30  # bytes of samples held for raw windows (they are computed in memory)


def adev_list(var: np.ndarray) -> list[Optional[float]]:
    """Deviations from variances, None where a variance is missing or negative."""
    return [json_num(math.sqrt(v)) if json_num(v) is not None and v >= 0 else None for v in var]


def load_windows(
    path: str,
    source: str = "auto",
    fs: Optional[float] = None,
    channels: Optional[list[str]] = None,
    window_s: Optional[float] = None,
    step_s: Optional[float] = None,
) -> tuple[Any, list[str]]:
    """The windows of ``path`` (dynamic.Windows) and notes about the choice."""
    from ..sources.detect import load

    return windows_of(load(path), path, source, fs, channels, window_s, step_s)


def windows_of(
    src: Any,
    path: str,
    source: str = "auto",
    fs: Optional[float] = None,
    channels: Optional[list[str]] = None,
    window_s: Optional[float] = None,
    step_s: Optional[float] = None,
    store: Any = None,
) -> tuple[Any, list[str]]:
    """``load_windows`` for a source already loaded (sources.load); ``store``:
    its samples already read by an analysis (store.py), channels ``channels``."""
    import numpy as np

    from ..channels import CHANNELS
    from ..device.records import decode_bytes
    from . import dynamic

    notes: list[str] = []
    reports = []
    # a device log (no samples) is read again for all its reports; a capture's
    # samples are used unless the reports are asked for (it is read once)
    if (source == "reports" or (source == "auto" and src.samples is None)) and path != "-":
        with open(path, "rb") as f:
            reports = decode_bytes(f.read()).reports
    runs = dynamic.runs(reports)
    use_reports = source == "reports" or (source == "auto" and runs and len(runs[-1]) >= 2)
    if use_reports:
        if not runs:
            raise InputError(f"'{src.name}': no complete device report in it")
        if len(runs) > 1:
            notes.append(f"{len(runs)} runs (a reset between reports): the last one used, {len(runs[-1])} reports")
        chans = [c for c in CHANNELS if channels is None or c in channels]
        return dynamic.from_reports(runs[-1], chans), notes
    if src.samples is None:
        raise InputError(
            f"'{src.name}': a single device report and no samples: nothing to split in "
            "windows (record with periodic reports: 'interval 60')"
        )
    rate = src.samples.fs or fs or (float(src.report.header.fs_hz) if src.report else None)
    if rate is None:
        raise InputError("the sample rate is unknown: give --fs HZ")
    sel = [i for i, c in enumerate(src.samples.channels) if channels is None or c in channels]
    temp = None
    streamed = store is not None and not store.held
    if src.samples.open_temperature is not None and not streamed:
        temp = np.concatenate(list(src.samples.open_temperature())).astype(np.float64).ravel()
    elif src.samples.open_temperature is not None:
        notes.append("temperature not read: the file was streamed (its temperature column would need a second pass)")
    if store is not None and store.n >= 64:
        return dynamic.from_store(store, rate, [src.samples.channels[i] for i in sel], window_s, step_s, temp), notes
    blocks, size = [], 0
    for b in src.samples.open_blocks():
        blocks.append(b[sel])
        size += b.shape[1] * len(sel) * 8
        if size > MEMORY:
            raise InputError(
                f"'{src.name}': more than {MEMORY >> 20} MB of samples: too large for "
                "windows in memory (cut the file, or record with periodic device reports)"
            )
    data = np.concatenate(blocks, axis=1).astype(np.float64)
    if data.shape[1] < 64:
        raise InputError(f"'{src.name}': {data.shape[1]} samples: too few for windows")
    chans = [src.samples.channels[i] for i in sel]
    return dynamic.from_samples(data, rate, chans, window_s, step_s, temp), notes
