"""imu-allan host tools: decode on-device Allan results, compute the float64
reference, analyze IMU noise.  The public Python API (api.py):

    import imu_allan
    dev = imu_allan.oadev(x, rate=100.0)          # also adev, mdev, hdev
    fit = imu_allan.noise_terms(x, rate=100.0)    # IEEE 952 Q N B K R
    cap = imu_allan.read_capture("device.log")    # samples and reports, checked
"""

__version__ = "0.1.0"

from .channels import CHANNELS  # noqa: E402
from .api import (Capture, Deviation, DeviceReport, adev, device_reports, hdev, mdev,  # noqa: E402
                  noise_terms, oadev, read_capture, read_rows)
from .stats import allan  # noqa: E402,F401  (bench/run.py: ``from imu_allan import allan``)

# bench/run.py still imports ``imu_allan.reference`` (now stats/reference.py):
# that old path stays importable until the bench moves to the new one.
import sys as _sys  # noqa: E402
from .stats import reference as _reference  # noqa: E402
_sys.modules.setdefault(__name__ + ".reference", _reference)

__all__ = ["CHANNELS", "Capture", "Deviation", "DeviceReport", "adev", "device_reports", "hdev",
           "mdev", "noise_terms", "oadev", "read_capture", "read_rows", "__version__"]
