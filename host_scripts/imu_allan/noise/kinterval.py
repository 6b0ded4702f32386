"""K's 95 % interval, and an absent K's bound, by test inversion (fit.py widens the
covariance's interval to it): each trial K judged under the weights of its own model, the
points read at their chi-squared quantiles for their EDF (NIST SP 1065 sections
5.2.3-5.2.4; IEEE Std 952-1997 annex C)."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable

import numpy as np

from ..stats.dist import Z95
from .curve import LINEAR, Structure, _Problem, columns


def k_interval(
    p: _Problem, s: Structure, theta: np.ndarray, extra: float = 0.0, start: float = 0.0
) -> tuple[float, float]:
    """95 % interval of K by test inversion: the K0 whose own model (the other terms of s
    refitted, under the weights of the model at K0) leaves the GLS estimate of K^2 within
    Z95 sd of K0^2, each point's deviation taken at its chi-squared quantile (_scores; the
    variance ``extra`` K0^4 added: the choice of structure's, fit.py, relative), searched
    from K^2 = ``start`` (the fitted one); (0, bound) where K0 = 0 is inside.  p's weights
    set back.

    An Allan estimate is chi-squared with Greenhall's EDF, its variance scaling with its mean
    (NIST SP 1065 sections 5.2.3-5.2.4; IEEE Std 952-1997 annex C), and on the last octaves
    the walk's share of the mean sets their one to eight degrees of freedom.  Judged under
    the fitted model's weights, a K is as sure as the fit is low at the curve's end: where a
    walk's realization ran low there, the interval or bound missed the truth on 12 textbook
    streams in 100 (on 11 of the 17 where K was left out; a log-AVAR profile did no better).
    Under the weights of each K0, the test's null, on the same streams: 99 in 100, and 99
    in 100 with the walk three times weaker (textbook white noise plus a walk, 16000 s)."""
    p.power = DECAY
    try:
        return _inversion(p, s, theta, extra, start)
    finally:
        p.power = 1.0
        p.set_reference(p.ref)


DECAY = 1.5
"""The decay of the octave correlation in K's inversion: d octaves apart RHO^(d^DECAY)
(terms.octave_correlation).  Overlapping Allan estimates of 600 textbook walks (2^16 samples)
correlate by 0.88, 0.67, 0.48, 0.34 at one to four octaves apart, where RHO^d (the
selection's, 0.86 an octave) gives 0.86, 0.74, 0.64, 0.55 and RHO^(d^1.5) 0.86, 0.65, 0.46,
0.30; flicker's 0.67, 0.31, 0.11 (RHO^d: 0.68, 0.46, 0.31; to d^1.5: 0.68, 0.34, 0.13).  A
walk rules K's points over several octaves, and its realization bends over them (low at the
crossing, high at the end): on six real gyros with walks of three sizes added (three draws
each) the truth fell outside K's interval on 22 of 162 under RHO^d, 18 under this form.  The
selection keeps RHO^d: with this form on every fit, three real channels lost a criterion of
N's (its level inside its interval, a shorter record's interval wider)."""


def _inversion(p: _Problem, s: Structure, theta: np.ndarray, extra: float, start: float) -> tuple[float, float]:
    """k_interval under p's weights as they stand (p.power set)."""
    s2 = replace(s, linear=tuple(x for x in LINEAR if x in s.linear or x == "K"))
    j = s2.names().index("K")
    A = columns(s2, theta, p.m, p.fs)
    ref0 = p.ref.copy()
    rest = np.delete(A, j, axis=1)

    def inside(u: float) -> bool:
        c, var = _k_at(p, A, rest, j, u, ref0)
        return abs(c - u) <= Z95 * math.sqrt(var + extra * u * u)

    # the fitted K, or from 8 times the K whose line meets one of the last points down to
    # 2^-8 of the one touching the curve from under, until one is inside; then its edges
    ratio = p.y / A[:, j]
    top, bottom = float(np.max(ratio[-4:])) * 64.0, float(np.min(ratio)) * 2.0**-16
    u0 = start if start > 0 and inside(start) else 0.0
    u = top
    while u0 == 0.0 and u > bottom:
        u0 = u if inside(u) else 0.0
        u /= STEP
    if u0 == 0.0:
        p.set_reference(ref0)
        return 0.0, 0.0
    hi = _edge(inside, u0, STEP, top)
    lo = _edge(inside, u0, 1.0 / STEP, bottom)
    p.set_reference(ref0)
    return math.sqrt(lo if lo > bottom else 0.0), math.sqrt(hi)


STEP = 2.0**0.5
"""The step in K^2 of the search for the edges of K's interval (then halved five times)."""


def _edge(inside: Callable[[float], bool], u: float, step: float, stop: float) -> float:
    """The last u inside going from u (inside) by factors ``step`` up to ``stop``, to
    2^(1/64) in K^2; ``stop`` itself when all is inside up to it."""
    while inside(u * step):
        u *= step
        if (u - stop) * (step - 1.0) >= 0:
            return stop
    a, b = u, u * step
    for _ in range(5):
        mid = math.sqrt(a * b)
        if inside(mid):
            a = mid
        else:
            b = mid
    return a


def _k_at(p: _Problem, A: np.ndarray, rest: np.ndarray, j: int, u: float, ref0: np.ndarray) -> tuple[float, float]:
    """The GLS estimate of K^2 (column j of A) and its variance under the weights of the model
    at K^2 = u (the other columns refitted, non-negative, PROFILE_ROUNDS times; those at 0 left
    out; ``rest`` A without column j), each point's deviation from that model taken at its
    chi-squared quantile (_scores)."""
    from .lsq import _least_squares, _nnls

    mod, co = ref0, np.zeros(rest.shape[1])
    for _ in range(PROFILE_ROUNDS):
        p.set_reference(mod)
        co = _nnls(p.gls.white(rest), p.yw - p.gls.white(A[:, j]) * u)
        mod = np.maximum(rest @ co + u * A[:, j], 1e-300)
    p.set_reference(mod)
    keep = [i for i in range(A.shape[1]) if i == j or co[i - (i > j)] > 0]
    c, cov = _least_squares(p.gls.white(A[:, keep]), p.gls.white(_scores(p, mod)))
    k = keep.index(j)
    return float(c[k]), max(float(cov[k, k]), 0.0)


def _scores(p: _Problem, mod: np.ndarray) -> np.ndarray:
    """The curve as the model ``mod`` with each point's normal score in its sd: the point is
    chi-squared with its EDF (the model error and capped influence lowering it), and a point
    far under a model of one to five degrees of freedom is rarer than its normal deviation
    says (at 0.14 of it, nu = 4: 3 %, not 11 %), one far over commoner.  Where nu is large
    it is the curve itself."""
    from scipy import special

    rel = (2.0 / p.e + p.floor**2) * p.robust  # relative variance of each point
    half = 1.0 / rel  # nu / 2
    x = p.y / mod * half  # chi2 / 2
    lower = special.gammainc(half, x)
    upper = special.gammaincc(half, x)
    z = np.where(lower < upper, special.ndtri(np.maximum(lower, 1e-300)), -special.ndtri(np.maximum(upper, 1e-300)))
    return mod * (1.0 + np.sqrt(rel) * z)


PROFILE_ROUNDS = 3
"""Rounds of the weights for each K tried (its model as the reference)."""
