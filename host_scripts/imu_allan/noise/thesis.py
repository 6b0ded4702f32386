"""The thesis' results table (section 7, Fs = 100 Hz) and its parameters as
``imu-allan gen`` arguments (ADC counts), for the worked example
(docs/thesis-example.md).

Units of the table. The thesis labels the accelerometer terms in m/s (N, B,
K) and sigma_sensor in m/s^2, the gyroscope ones in degrees. Read as
written, the accelerometers' white noise would be sigma_sensor = 7.57e-3
m/s^2 = 0.19 counts, below one ADC step, while the thesis' own raw rows
(section 6: ax 496 .. 503) scatter by about 2 counts. In g, 7.57e-3 g is
1.88 counts, as the rows show (and the gyroscopes, in deg/s, agree with
their rows: 0.827 deg/s = 0.85 counts). So the accelerometer figures are in
g (g*sqrt(s), g, g/sqrt(s)); this module reads them so and converts them to
m/s^2 with g = 9.80665. Their N is sigma / sqrt(Fs) (N = 7.2e-4 with
sigma_AVRW = 7.56e-3 at 100 Hz): the IEEE 952 N in u*sqrt(s), u = g or deg/s.

To counts with the thesis profile (1.5 g range):
    white   = sqrt((N sqrt(fs) / c)^2 - 1/12)   the ADC rounding adds 1/12 count^2
                                                  of white noise, already in the
                                                  thesis' measured N
    flicker = B / c                              IEEE 952 B (gen --flicker)
    rrw     = K / c / sqrt(fs)                   random walk step per sample
with c = 3.3 / 1024 / 0.8 g = 4.0283e-3 g (accelerometers) and
3.3 / 1024 / 0.0033 = 0.97656 deg/s (gyroscopes) per count.
"""

from __future__ import annotations

import math
from typing import Optional

from ..profiles import G0, thesis_profile

FS = 100.0
# sensor: N, B, K, sigma_sensor, sigma_bias, sigma_AVRW, sigma_ARRW, FIT %  (as printed, 100 Hz)
TABLE_100HZ: dict[str, tuple[float, float, Optional[float], float, float, float, Optional[float], float]] = {
    "ax": (7.2e-4, 3.37e-4, 4.2e-5, 7.57e-3, 7.45e-4, 7.56e-3, 5.00, 98.58),
    "ay": (7.2e-4, 4.11e-4, 8.8e-5, 9.43e-3, 1.29e-3, 9.42e-3, 5.00, 98.54),
    "az": (6.2e-4, 1.30e-4, 7.5e-6, 6.57e-3, 1.43e-4, 6.57e-3, 9.00, 98.58),
    "gx": (8.2e-2, 5.47e-2, None, 8.27e-1, 1.71e-1, 8.25e-1, None, 98.59),
    "gy": (6.5e-2, 5.12e-2, None, 5.64e-1, 5.65e-2, 5.61e-1, None, 98.59),
    "gz": (5.4e-2, 4.96e-2, None, 4.78e-1, 5.48e-2, 4.76e-1, None, 98.59),
}
COLUMNS = ("N", "B", "K", "sigma_sensor", "sigma_bias", "sigma_AVRW", "sigma_ARRW", "FIT")


def native_unit(ch: str) -> str:
    """The unit the thesis' numbers are in (see the module docstring)."""
    return "g" if ch[0] == "a" else "deg/s"


def per_count_native(ch: str, range_g: str = "1.5") -> float:
    sc = thesis_profile(range_g).scale(ch)
    return sc.per_count / G0 if ch[0] == "a" else sc.per_count


def terms_si(ch: str) -> dict[str, Optional[float]]:
    """The thesis' N, B, K of ``ch`` in the JSON units (u = m/s^2 or deg/s)."""
    N, B, K = TABLE_100HZ[ch][:3]
    f = G0 if ch[0] == "a" else 1.0
    return {"N": N * f, "B": B * f, "K": None if K is None else K * f}


def gen_params(fs: float = FS, range_g: str = "1.5") -> dict[str, dict[str, float]]:
    """``imu-allan gen`` parameters (counts) that reproduce the table's N, B, K."""
    out: dict[str, dict[str, float]] = {"white": {}, "flicker": {}, "rrw": {}, "gm_sigma": {}}
    for ch, row in TABLE_100HZ.items():
        N, B, K = row[:3]
        c = per_count_native(ch, range_g)
        sigma = N * math.sqrt(fs) / c
        out["white"][ch] = math.sqrt(max(sigma * sigma - 1.0 / 12.0, 0.0))
        out["flicker"][ch] = B / c
        out["rrw"][ch] = (K or 0.0) / c / math.sqrt(fs)
        out["gm_sigma"][ch] = 0.0
    return out


def gen_spec(fs: float = FS) -> list[str]:
    """The ``imu-allan gen`` options of ``gen_params``, rounded to 4 significant digits."""
    p = gen_params(fs)
    args = []
    for name in ("white", "flicker", "rrw", "gm_sigma"):
        spec = ",".join(f"{ch}={v:.4g}" for ch, v in p[name].items())
        args += [f"--{name.replace('_', '-')}", spec]
    return args
