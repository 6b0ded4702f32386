"""What every reader hands the statistics: the samples of a file as blocks, and what it says."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Iterator, Optional

import numpy as np

from ..device.records import DeviceHeader, DeviceReport

TEMP_NOTE = "column 7 (temp) not used by the noise analysis (imu-allan thermal reads it)"
"""No column is dropped silently: the thesis rows' temperature is named as unused."""

KIND_NAMES = {
    "rows": "rows file",
    "csv": "CSV",
    "capture": "device capture",
    "rosbag": "ROS bag",
    "npy": "NumPy array",
    "device-log": "device log (on-device results only)",
}
"""Every kind of source a reader makes (``SampleSource.kind``, and a device log
alone), as the text names it."""


@dataclass
class SampleSource:
    kind: str  # a key of KIND_NAMES
    name: str
    channels: list[str]  # subset of CHANNELS, in file order of CHANNELS
    open_blocks: Callable[[], Iterator[np.ndarray]]
    integer: bool  # ADC codes
    fs: Optional[float] = None  # from a time column, header stamps or a device header
    n_hint: Optional[int] = None  # expected samples (progress bars), may be None
    size_bytes: Optional[int] = None
    units: dict[str, str] = field(default_factory=dict)  # from the header or the format's definition
    notes: list[str] = field(default_factory=list)
    open_temperature: Optional[Callable[[], Iterator[np.ndarray]]] = None
    """Blocks of the temperature column's codes, aligned with ``open_blocks``
    (rows files and captures carry it; CSV does not)."""
    time: Any = None
    """The timing.TimeCheck of the time column or stamps (None without one):
    after a whole pass its ``found`` holds rows, span, gaps."""
    topic: Optional[str] = None  # a bag's topic


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
