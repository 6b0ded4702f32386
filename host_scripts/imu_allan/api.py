"""The public Python API, for a notebook: flat functions in the allantools
spirit, all with the same shape.

    dev = imu_allan.oadev(data, rate=100.0, taus="octave")
    dev.taus, dev.devs, dev.low, dev.high, dev.edf, dev.ns

``data`` is one channel of rate samples ("frequency data" in NIST SP 1065:
deg/s, m/s^2 or ADC codes), ``rate`` the sample rate in Hz, ``taus`` a grid
name ("octave": m = 1, 2, 4 ...; "decade"; "log"; "all") or an array of
averaging times in seconds (rounded to whole samples).  Every statistic
returns a ``Deviation``: the taus actually used, the deviation, its 95 %
confidence interval (chi-squared with Greenhall's equivalent degrees of
freedom, NIST SP 1065 section 5.2, the noise type taken from the curve's
local slope) and the number of terms behind each value.

The device side: ``read_capture`` (raw rows, binary frames and reports of a
serial log, checked), ``device_reports`` (every complete on-device report),
``read_rows`` (a thesis rows file).  ``noise_terms(data, rate, taus)`` fits
the IEEE 952 terms (IEEE Std 952-1997 annex C: Q, N, B, K, R).
"""

from __future__ import annotations

from typing import Callable, NamedTuple, Union

import numpy as np
from numpy.typing import ArrayLike

from .device.capture import Capture, read_capture
from .device.files import PathLike, read_blocks
from .device.records import DeviceReport, decode_blocks
from .noise import terms
from .sources.rows import read_rows
from .stats import allan, edf

Taus = Union[str, ArrayLike]
Variance = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
"""A statistic of stats/allan.py: (samples, cluster sizes) -> (variances, terms)."""

__all__ = [
    "Deviation",
    "adev",
    "oadev",
    "mdev",
    "hdev",
    "noise_terms",
    "read_capture",
    "device_reports",
    "read_rows",
    "Capture",
    "DeviceReport",
]


class Deviation(NamedTuple):
    taus: np.ndarray
    """Averaging times, s."""
    devs: np.ndarray
    """The deviation, in the unit of the data."""
    low: np.ndarray
    """Lower end of the 95 % interval."""
    high: np.ndarray
    """Upper end of the 95 % interval."""
    edf: np.ndarray
    """Equivalent degrees of freedom behind each interval."""
    ns: np.ndarray
    """Terms (differences) averaged at each tau."""


def adev(data: ArrayLike, rate: float = 1.0, taus: Taus = "octave") -> Deviation:
    """Non-overlapping Allan deviation (NIST SP 1065 eq. 6; IEEE 952 eq. C.2):
    the statistic the device computes on-chip."""
    return _deviation(data, rate, taus, allan.avar, "adev", d=2, overlapping=False)


def oadev(data: ArrayLike, rate: float = 1.0, taus: Taus = "octave") -> Deviation:
    """Overlapping Allan deviation (NIST SP 1065 eq. 8): every offset of each
    cluster size, the usual estimate for noise identification."""
    return _deviation(data, rate, taus, allan.oavar, "oavar", d=2, overlapping=True)


def mdev(data: ArrayLike, rate: float = 1.0, taus: Taus = "octave") -> Deviation:
    """Modified Allan deviation (NIST SP 1065 eq. 14): separates white and
    flicker phase noise."""
    return _deviation(data, rate, taus, allan.mvar, "mvar", d=2, overlapping=True, modified=True)


def hdev(data: ArrayLike, rate: float = 1.0, taus: Taus = "octave") -> Deviation:
    """Overlapping Hadamard deviation (NIST SP 1065 eq. 18): insensitive to a
    linear drift (rate ramp)."""
    return _deviation(data, rate, taus, allan.ohvar, "mvar", d=3, overlapping=True)


def noise_terms(data: ArrayLike, rate: float = 1.0, taus: Taus = "octave") -> terms.FitResult:
    """Noise terms of one channel: the catalogue (imu_allan.noise) fitted to its
    whole overlapping Allan variance curve, weighted by the estimates'
    covariance (Greenhall's EDF; IEEE Std 952-1997 annex C; NIST SP 1065
    section 5.2).  ``result.terms["N"].value`` etc. (Q N B K R, in the unit of
    the data times s^(1/2) and so on), and when the data need them ``"LP"``
    (a band limit: ``.extra["fc"]``, ``["order"]``) and ``"GM1"``, ``"GM2"``
    (Gauss-Markov: value sigma, ``.extra["tau_c"]``); ``result.fitted`` the
    catalogue model (docs/analysis.md)."""
    from .noise.fit import fit_curve

    x, ms = _grid(data, rate, taus, "oavar")
    var, _ = allan.oavar(x, ms)
    efn = edf.edf_function(ms, np.full(ms.size, x.size + 1), np.ones(ms.size, dtype=np.int64))
    return fit_curve(ms / float(rate), var, efn, fs=float(rate), overlapping=True)


def device_reports(path: PathLike) -> list[DeviceReport]:
    """Every complete, CRC-checked report of a device log, in order."""
    return decode_blocks(read_blocks(path)).reports


def _deviation(
    data: ArrayLike, rate: float, taus: Taus, fn: Variance, stat: str, d: int, overlapping: bool, modified: bool = False
) -> Deviation:
    x, ms = _grid(data, rate, taus, stat)
    var, ns = fn(x, ms)
    ok = np.isfinite(var) & (var > 0)
    ms, var, ns = ms[ok], var[ok], np.asarray(ns)[ok]
    tau = ms / float(rate)
    alpha = terms.local_alpha(tau, var) if tau.size else np.zeros(0, dtype=np.int64)
    if d == 3:
        alpha = np.maximum(alpha, -4)
    stride = np.ones(ms.size, dtype=np.int64) if overlapping else ms
    table = edf.edf_points(
        ms,
        np.full(ms.size, x.size + 1),
        stride,
        d=d,
        modified=modified,
        alphas=tuple(sorted(set(int(a) for a in alpha))) or (0,),
    )
    e = np.empty(ms.size)
    for a, vals in table.items():
        e[alpha == a] = vals[alpha == a]
    lo, hi = edf.chi2_interval(var, e)
    return Deviation(tau, np.sqrt(var), np.sqrt(lo), np.sqrt(hi), e, ns)


def _grid(data: ArrayLike, rate: float, taus: Taus, stat: str) -> tuple[np.ndarray, np.ndarray]:
    """One channel and its cluster sizes m (whole samples, at least one term each)."""
    x = np.asarray(data).ravel()
    if x.size < 4:
        raise ValueError(f"{x.size} samples: too few for any statistic")
    if not rate > 0:
        raise ValueError(f"rate must be positive: {rate}")
    top = allan.max_m(stat, x.size)
    if isinstance(taus, str):
        return x, allan.tau_grid(taus, top)
    ms = np.unique(np.rint(np.asarray(taus, dtype=np.float64) * rate).astype(np.int64))
    return x, ms[(ms >= 1) & (ms <= top)]
