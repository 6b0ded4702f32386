"""imu-allan host tools: decode on-device Allan results, compute the float64
reference, analyze IMU noise.  The public Python API (api.py):

    import imu_allan
    dev = imu_allan.oadev(x, rate=100.0)          # also adev, mdev, hdev
    fit = imu_allan.noise_terms(x, rate=100.0)    # IEEE 952 Q N B K R
    cap = imu_allan.read_capture("device.log")    # samples and reports, checked

The API's names are loaded on first use (PEP 562), so that ``imu-allan
--help`` and the serial commands start without importing numpy and scipy.
"""

from __future__ import annotations

from typing import Any

from ._version import __version__
from .channels import CHANNELS

_API = (
    "Capture",
    "Deviation",
    "DeviceReport",
    "adev",
    "device_reports",
    "hdev",
    "mdev",
    "noise_terms",
    "oadev",
    "read_capture",
    "read_rows",
)

__all__ = ["CHANNELS", *_API, "__version__"]


def __getattr__(name: str) -> Any:
    if name in _API:
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_API))
