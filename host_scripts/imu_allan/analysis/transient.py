"""Where a warm-up ends: the transient's shape fitted over the windows'
statistics (docs/dynamic.md, section 3).

The departure test (dynamic.py) finds the leading stretch of windows that
depart, each on its own at the family-wise level.  A weak transient departs
only while it is large against one window's noise, so that stretch ends
where the transient stops being significant per window, long before the
transient itself ends.  Here the excess ``x = v_w / v_R - 1`` of the stretch
and the windows just after it, at the taus that departed, is fitted by one
shape in time times one amplitude per tau, ``x[w, k] = a_k g_w``, with
``g_w`` the shape's mean over window w:

* an exponential decay ``exp(-t / theta)`` (an exponential drift adds
  ``slope^2`` to the Allan variance, a settling extra noise its variance:
  both decay so), open;
* or, when the windows show the transient stop (chi-squared lower by
  ``STOP_CHI2``), the same decay cut at a time E, or ``(1 - t / E)^p``
  (a noise level settling linearly reaches zero at E, p = 2).

The warm-up ends where the transient's amplitude (the square root of the
variance it adds) has fallen to ``SETTLED`` of its start, or at the stop:
the 95 % settling time of the fitted shape.  It is an extrapolation of a
decay measured in the first windows, not a detection: a transient that
changes its shape after the windows stop showing it is not seen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

SETTLED = 0.05
"""The transient is over when its amplitude is below this fraction of its start (95 % settled)."""
STOP_CHI2 = 3.84
"""A shape that stops replaces the open exponential only when it lowers the
fit's -2 log-likelihood by this much (one more parameter: chi-squared(1)'s
95 % point), divided by 1 - the windows' overlap (overlapping windows count
their shared samples twice)."""
POWERS = np.array([0.5, 1, 1.5, 2, 3, 4, 6, 8, 12, 16, 24], dtype=np.float64)
"""The exponents p of the stopping shape (1 - t / E)^p tried."""
SPAN = 0.5
"""The fit reads the windows that start before the stretch's last window ends
plus this fraction of the stretch: the ones that still carry its tail."""


@dataclass
class Transient:
    end_s: float
    shape: str  # "exponential", "exponential, stopped" or "(1 - t/E)^p"
    decay_s: Optional[float]  # the amplitude's time constant (2 theta), for the exponential shapes
    stop_s: Optional[float]  # where a stopping shape reaches zero
    stretch_s: float  # where the departing stretch alone ends (the first calm window's start)
    stop_gain: float = 0.0  # the chi-squared a stopping shape gains over the open exponential


def _mean_exp(t0: np.ndarray, t1: np.ndarray, theta: np.ndarray, stop: np.ndarray) -> np.ndarray:
    """(theta, stop, W): the mean of exp(-t / theta) over each window, zero after ``stop``."""
    th, e = theta[:, None, None], stop[None, :, None]
    a, b = t0[None, None, :], np.minimum(t1[None, None, :], e)
    val = th * (np.exp(-a / th) - np.exp(-np.maximum(a, b) / th)) / (t1 - t0)[None, None, :]
    return np.where(a < e, val, 0.0)


def _mean_power(t0: np.ndarray, t1: np.ndarray, p: np.ndarray, stop: np.ndarray) -> np.ndarray:
    """(p, stop, W): the mean of (1 - t / stop)^p over each window, zero after ``stop``."""
    pp, e = p[:, None, None], stop[None, :, None]
    a, b = t0[None, None, :], np.minimum(t1[None, None, :], e)
    ua, ub = np.clip(1 - a / e, 0, None), np.clip(1 - np.maximum(a, b) / e, 0, None)
    val = e / (pp + 1) * (ua ** (pp + 1) - ub ** (pp + 1)) / (t1 - t0)[None, None, :]
    return np.where(a < e, val, 0.0)


def _fit(g: np.ndarray, x: np.ndarray, w0: np.ndarray) -> tuple[float, int, int]:
    """Least squares of x (W, K) by a_k g (grid, grid, W), a_k >= 0 per grid point;
    weights w0 / (1 + model): a deterministic drift's excess varies with the
    cross term, sqrt(1 + x) times the noise's.  The best grid point and its chi2."""
    wt = np.broadcast_to(w0, g.shape[:2] + w0.shape)
    for _ in range(2):
        num = np.einsum("abw,abwk,wk->abk", g, wt, x)
        den = np.einsum("abw,abwk->abk", g * g, wt)
        amp = np.clip(num / np.maximum(den, 1e-300), 0, None)
        model = g[..., None] * amp[:, :, None, :]
        wt = w0 / (1 + model)
    use = w0 > 0  # -2 log-likelihood: the chi2 and each point's variance, (1 + model) / w0
    chi2 = (wt * (x - model) ** 2 + np.where(use, np.log1p(model), 0.0)).sum(axis=(2, 3))
    i, j = np.unravel_index(int(np.argmin(chi2)), chi2.shape)
    return float(chi2[i, j]), int(i), int(j)


def warmup_end(
    t0: np.ndarray,
    t1: np.ndarray,
    x: np.ndarray,
    edf: np.ndarray,
    tested: np.ndarray,
    hits: np.ndarray,
    last: int,
    overlap: float = 0.0,
) -> Optional[Transient]:
    """The end of the warm-up whose departing stretch is windows 0..``last``:
    ``x`` (W, K) each window's excess over its reference, ``edf`` its EDF,
    ``tested`` the points tested, ``hits`` the points that departed,
    ``overlap`` the fraction of a window shared with the next.  None when
    nothing is left to fit or the fitted transient would not have settled in
    the record's first half (the stretch's own end stands)."""
    stretch = float(t0[last + 1])
    near = np.asarray(t0 < t1[last] + SPAN * (t1[last] - t0[0]))
    taus = np.asarray(hits[: last + 1].any(axis=0))
    use = tested & near[:, None] & taus[None, :] & np.isfinite(x)
    if not use.any():
        return None
    x = np.where(use, x, 0.0)
    w0 = np.where(use, np.nan_to_num(edf) / 2.0, 0.0)  # 1 / var of a ratio of chi2 / EDF
    span = float(t1.max() - t0.min())
    step = float(np.median(np.diff(t0))) if t0.size > 1 else span
    theta = np.geomspace(step / 4, span, 160)
    stops = np.arange(t0[last] + step / 4, t1.max(), step / 4)
    c_open, i_open, _ = _fit(_mean_exp(t0, t1, theta, np.array([np.inf])), x, w0)
    c_cut, i_cut, j_cut = _fit(_mean_exp(t0, t1, theta, stops), x, w0)
    c_pow, i_pow, j_pow = _fit(_mean_power(t0, t1, POWERS, stops), x, w0)
    settle = 2 * math.log(1 / SETTLED)  # amplitude exp(-t / (2 theta)) down to SETTLED
    if c_open - min(c_cut, c_pow) <= STOP_CHI2 / (1.0 - overlap):
        th = float(theta[i_open])
        out = Transient(settle * th, "exponential", 2 * th, None, stretch)
    elif c_cut <= c_pow:
        th, e = float(theta[i_cut]), float(stops[j_cut])
        out = Transient(min(settle * th, e), "exponential, stopped", 2 * th, e, stretch)
    else:
        p, e = float(POWERS[i_pow]), float(stops[j_pow])
        out = Transient(e * (1 - SETTLED ** (2 / p)), f"(1 - t/E)^{p:g}", None, e, stretch)
    if out.end_s > 0.5 * (t0.min() + t1.max()):
        return None  # not settled in the first half, the departure test's reference: no transient of this shape
    out.end_s = max(out.end_s, stretch)  # never before the departing windows end
    out.stop_gain = c_open - min(c_cut, c_pow)
    return out
