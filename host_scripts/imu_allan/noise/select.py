"""Model selection of the whole-curve fit (fit.py): which processes the curve needs.

The IEEE 952 terms first (stepwise, terms.py), then a band limit (replacing
white N by the low-passed one; order 1 or 2, whichever fits better) and up to
MAX_GM Gauss-Markov processes are each kept only when they lower chi-squared
by the 95 % point of chi2 with their number of parameters (times chi2/dof when
above 1: an F test; each against the same terms without it as well, and the
band limit only where the curve can show its bend: _lp_shows); then each linear
term whose removal costs less than 3.84 is dropped.  A first process that fails its
test beside the terms already in may still take their place (_gm_in_place): a hump
whose peak lies more than RISE_OCTAVES before the last tau, which flicker and a rate
random walk together mimic, kept in place of the walk (or a ramp) when it wins by the
information criterion with no rise left beside it.  A sinusoid is tried last
(where the curve shows an oscillation's hump, or where the largest model error
leaves the first model off the curve), started where the model leaves its
largest hump.  On a real sensor
(chi2/dof above 1 at the first selection) the selection runs again with the
model error in the weights (by tau region: curve.set_floor; the resonance judged under
the error the model with it needs) and points far off the model given capped
influence; the first structure, refitted under the same weights, stays when
the information criterion prefers it.  Where the structure then holds a sinusoid and a band
limit but no resonance, a resonance is judged again at chance (_res_at_chance: the error
was set by a first model without the sinusoid, whose hump's misfit reached the first
points and hid a mount mode there).  Last, a rise at the curve's end taken by a
ramp, a long Gauss-Markov process or a sinusoid is read as K unless they beat K on
log AVAR by the 99.9 % point (_rise_as_k); the weights of the structure chosen are
iterated to their fixed point (converge).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable

import numpy as np

from ..stats import dist
from ..stats.dist import Z95
from .curve import (
    LINEAR,
    MODEL_ERR,
    ROBUST_SHARE,
    ROBUST_Z,
    Structure,
    _Problem,
    bounds,
    columns,
    covariance,
    fit_structure,
    local_floor,
    log_chi2,
    misfits,
    residual_dof,
    set_floor,
    settle,
)
from .processes import FC_CEILING
from .reading import _unexplained
from .terms import CHI2_1_95

MAX_GM = 2
LP_FORMS = (("pole", 1), ("pole", 2), ("average", 1), ("average", 2), ("pole_mean", 1), ("pole", 4))
"""The band limits tried: a one-pole RC, a two-pole Butterworth, a moving average, two
averages in cascade (the Bartlett window of parts that average at an internal rate), an RC
whose output each sample averages (a record averaged down: the one form whose cutoff may lie
above fs / 2; there one order is all the curve can tell, the filter's delay), a four-pole
Butterworth (a steeper DLPF, whose sharper bend the others left to a sinusoid at its cutoff)."""
CLASSIC_POLES = (1, 2)
"""The pole orders the band limit's form is chosen among by chi2 alone; the others are forms
that must fit decisively better (_lp_form)."""
CHI2_1_999 = 10.83
"""The 99.9 % point of chi2 with one degree of freedom."""
SINE = False
"""Try a sinusoid (an oscillation's hump, ADEV peak at 0.371 / f0, two octaves or more inside
the curve) after the GM processes on every curve; otherwise only where the first fit leaves a
hump whose excess falls like an oscillation's (elsewhere it would trade against K and the GMs)."""


def choose(
    t: np.ndarray,
    y: np.ndarray,
    fs: float,
    edf_of: Callable,
    kind: str,
    lin: tuple[str, ...],
    extended: bool,
) -> tuple[_Problem, Structure, np.ndarray]:
    """The structure the curve (t, y) needs and its nonlinear parameters, with the
    problem (weights) it was fitted under."""

    def select(floor: np.ndarray, robust: bool = False, sine: bool = False) -> tuple[_Problem, Structure, np.ndarray]:
        p = _Problem(t, y, fs, edf_of, kind, floor)
        p.robust_on, p.sine_on = robust, sine or SINE
        s, theta, c, chi2 = _stepwise(p, Structure(lin), np.zeros(0))
        if extended and "N" in lin and t.size >= 4:
            s, theta, c, chi2 = _extend(p, s, theta, c, chi2, lin)
        return p, s, theta

    p, s, theta = select(np.zeros(t.size))
    c, chi2, _ = p.solve(s, theta)
    floor = set_floor(p, s, theta, c, residual_dof(p, c, theta))
    if floor.any():  # a real sensor: select again, the model error in the weights, robustly
        # a sinusoid where the curve shows an oscillation's hump, or where no model error the
        # fit may grant brings the first model to the curve (the one process not tried yet)
        osc = floor.max() >= 2.0 * MODEL_ERR or _shows_oscillation(p, s, theta)
        s1, th1 = s, theta
        p, s, theta = select(floor, robust=True, sine=osc)
        # the first structure under the same weights: the robust selection may wander off
        p1 = _Problem(t, y, fs, edf_of, kind, floor)
        p1.robust_on = True
        th1, c1, chi1 = fit_structure(p1, s1, th1, None)
        c2, chi2_, _ = p.solve(s, theta)
        if chi1 + 2 * (np.sum(c1 > 0) + th1.size) < chi2_ + 2 * (np.sum(c2 > 0) + theta.size):
            p, s, theta = p1, s1, th1
    if extended and floor.any() and s.sine:  # the mode the first model's error hid (_res_at_chance)
        p, s, theta = _res_at_chance(_Problem(t, y, fs, edf_of, kind), p, s, theta, lin)
    if extended and "K" in lin:
        s, theta = _rise_as_k(p, s, theta)
    converge(p, s, theta)  # the weights of the model chosen, not of the last candidate tried
    return p, s, theta


def _res_at_chance(
    pc: _Problem, p: _Problem, s: Structure, theta: np.ndarray, lin: tuple[str, ...]
) -> tuple[_Problem, Structure, np.ndarray]:
    """A resonance (a mount mode) judged at chance (pc: no model error) beside a structure that
    holds a sinusoid and a band limit, as _try_res judges it.  The model error of the first
    selection was set by a model without the sinusoid (tried under the error only): its hump's
    misfit, granted over the windows that reach the first points, hid the mode, whose evidence
    is the first points' own precision, and the band limit's bend and N traded for it (a real
    accelerometer's N read 3-7 % higher at 100 Hz than averaged down by 10, where the mode is
    gone).  Kept, the structure is refitted under the model error it needs (set_floor), and the
    resonance stays only where that error leaves it pinned (_res_pinned), and below the band
    limit's cutoff (the part's filter would take a mount mode above it; there it stood in for a
    filter steeper than the catalogue's and traded with flicker)."""
    if s.res or not s.lp or pc.t.size - (len(lin) + s.ngm + len(s.nonlinear()) + 3) < 2:
        return p, s, theta
    base = replace(s, linear=tuple(k for k in lin if k != "Q"))
    th, c, chi2 = fit_structure(pc, base, theta, None)
    s2 = replace(base, res=1)
    th2, c2, chi2b = fit_structure(pc, s2, _res_grid(pc, base, th), None)
    k = s2.names().index("RES")
    dof = residual_dof(pc, c2, th2)
    if not (c2[k] > 0 and _test(chi2 - chi2b, chi2b, dof, 3) and _shows(pc, s2, th2, c2, k, RES_SHARE)):
        return p, s, theta
    if th2[s2.res_at()] > th2[0]:  # beyond the band limit's cutoff: the part's filter would take a mode
        return p, s, theta
    if not _res_pinned(pc, s2, th2, c2):
        return p, s, theta
    s2, th2, c2, _ = _stepwise(pc, s2, th2, keep=("N",))
    floor = set_floor(pc, s2, th2, c2, residual_dof(pc, c2, th2))
    p2 = _Problem(pc.t, pc.y, pc.fs, pc.edf_of, pc.kind, floor)
    p2.robust_on = True
    th2, c2, _ = fit_structure(p2, s2, th2, None)
    if c2[s2.names().index("N")] > 0 and _res_pinned(p2, s2, th2, c2):
        return p2, s2, th2
    return p, s, theta


def converge(p: _Problem, s: Structure, theta: np.ndarray, rounds: int = 30, tol: float = 1e-3) -> None:
    """The weights set to the model of s at theta, and the model refitted under them, until
    the two agree (a fixed point; each reference the geometric mean of the last one and the
    model: on the last octaves, where the weights scale with the model, an undamped round
    can swing K from half its value to twice and to 0 in turn)."""
    settle(p, s, theta)
    for _ in range(rounds):
        c, _, A = p.solve(s, theta)
        mod = np.maximum(A @ c, 1e-300)
        ref = np.sqrt(p.ref * mod)
        # a curve point of exactly 0 (a channel that never moved) leaves its reference at 0
        step = float(np.max(np.abs(np.log(np.maximum(ref, 1e-300) / np.maximum(p.ref, 1e-300)))))
        p.set_reference(ref)
        if p.robust_on:
            z = (p.y - mod) / p.gls.sd
            far = np.abs(z) > ROBUST_Z
            if np.mean(far) <= ROBUST_SHARE:
                p.robust = np.maximum(1.0, (z / ROBUST_Z) ** 2)
                p.set_reference(ref)
        if step < tol:
            break


RISE_OCTAVES = 3.0
"""A ramp, a Gauss-Markov process whose ADEV peaks (1.89 T) or a sinusoid whose ADEV peaks
(0.371 / f0) within this many octaves of the last tau, or beyond, is a rival of K for the
rise at the curve's end."""
RISE_LEVEL = 0.999
"""The rivals must beat K by this point of chi2 (degrees of freedom: their parameters beyond
K's, at least one) on the log-AVAR scale."""


def _rivals(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray) -> tuple[bool, list[int], bool]:
    """(R, the GMs, the sinusoid) of s that take the rise at the curve's end."""
    names = s.names()
    near = p.t[-1] * 2.0**-RISE_OCTAVES
    r = "R" in s.linear and c[names.index("R")] > 0
    i0 = 1 if s.lp else 0
    gms = [j for j in range(s.ngm) if c[names.index(f"GM{j + 1}")] > 0 and 1.89 * math.exp(theta[i0 + j]) >= near]
    sine = bool(s.sine) and c[names.index("SIN")] > 0 and 0.371 / math.exp(theta[-1]) >= near
    return r, gms, sine


def _rise_as_k(p: _Problem, s: Structure, theta: np.ndarray) -> tuple[Structure, np.ndarray]:
    """A rise at the curve's end is read as K (IEEE 952: a +1/2 slope) unless a ramp, a long
    Gauss-Markov process or a sinusoid beats K by the RISE_LEVEL point on the log-AVAR scale,
    or fits the curve at chance where K's structure misfits it as a whole.

    The last octaves hold a few degrees of freedom: their estimates are chi-squared with one
    to five, skewed far from the normal the weights assume (a point 5 times its mean costs
    a normal weight 4 times what the chi-squared gives it), and a finite record of a random
    walk carries a trend of its own (the least-squares slope of a walk over T has variance
    1.2 K^2 / T: its AVAR at T / 2 matches K's line), so a +1 or a bending rise there is
    weak evidence against K.  Both structures are judged by log AVAR (Bartlett and Kendall
    1946: log chi2_nu / nu has variance psi'(nu / 2), mean psi(nu / 2) - log(nu / 2)), each
    under its own weights."""
    c, _, _ = p.solve(s, theta)
    r, gms, sine = _rivals(p, s, theta, c)
    if not (r or gms or sine):
        return s, theta
    i0 = 1 if s.lp else 0
    drop = [i0 + j for j in gms] + ([theta.size - 1] if sine else [])
    lin = tuple(k for k in LINEAR if (k in s.linear and k != "R") or k == "K")
    sk = replace(s, linear=lin, ngm=s.ngm - len(gms), sine=0 if sine else s.sine)
    # from the curve's own weights: under the rivals' (their model dips or bends at the end)
    # K's fit could stay at 0, each model's weights holding it there
    p.set_reference(p.y)
    thk = fit_structure(p, sk, np.delete(theta, drop), None)[0]
    converge(p, sk, thk)
    ck, _, A = p.solve(sk, thk)
    if ck[sk.names().index("K")] <= 0:
        return s, theta
    lk = log_chi2(p, A @ ck)
    converge(p, s, theta)
    c, _, A = p.solve(s, theta)
    ls = log_chi2(p, A @ c)
    extra = max(1, int(np.sum(c > 0)) + theta.size - int(np.sum(ck > 0)) - thk.size)
    if lk - ls >= float(dist.chi2_ppf(RISE_LEVEL, extra)):
        return s, theta
    # the level guards K against the last octaves' skew, not against a misfit of the whole
    # curve: a walk cannot follow a hump the curve falls from
    if misfits(lk, residual_dof(p, ck, thk)) and not misfits(ls, residual_dof(p, c, theta)):
        return s, theta
    return sk, thk


def shown(p: _Problem, s: Structure, theta: np.ndarray, k: str) -> bool:
    """The curve shows term k beyond doubt on log AVAR: the structure without it, under its
    own weights, costs CHI2_1_95 more (p's weights set back to s).  A rate random walk read
    off the last octaves has a coefficient whose sd, under weights that grow with the model,
    can reach half its value while a curve twice N's line says plainly that it is there.
    Judged with no point's influence capped: the model without k would have its evidence,
    the points it leaves far off, counted at 3 sd."""
    s0 = replace(s, linear=tuple(x for x in s.linear if x != k))
    saved = p.robust, p.robust_on
    p.robust, p.robust_on = np.ones(p.t.size), False
    gain = 0.0
    for sign, s1 in ((1.0, s0), (-1.0, s)):
        p.set_reference(p.y)
        converge(p, s1, theta)
        c1, _, A1 = p.solve(s1, theta)
        gain += sign * log_chi2(p, A1 @ c1)
    p.robust, p.robust_on = saved
    converge(p, s, theta)
    return gain >= CHI2_1_95


def _shows_oscillation(p: _Problem, s: Structure, theta: np.ndarray) -> bool:
    """A sinusoid is tried only where the curve shows an oscillation's hump: left
    unexplained by the first model, or by it without its Gauss-Markov processes (a GM
    may have stood in for the hump, not fitting it)."""
    forms = [(s, theta)]
    if s.ngm:
        forms.append(_without_gms(s, theta))
    for s1, th1 in forms:
        c, _, A = p.solve(s1, th1)
        if any(r["kind"] in ("oscillation", "hump") for r in _unexplained(p, A @ c, p.e)):
            return True
    return False


def _without_gms(s: Structure, theta: np.ndarray) -> tuple[Structure, np.ndarray]:
    """s without its Gauss-Markov processes: their times leave theta, and the parameters after
    them (a resonance's, a sinusoid's) stay."""
    i0 = 1 if s.lp else 0
    return replace(s, ngm=0), np.delete(theta, np.arange(i0, i0 + s.ngm))


def _test(gain: float, chi2_big: float, dof_big: int, params: int) -> bool:
    q = CHI2_1_95 if params == 1 else float(dist.chi2_ppf(0.95, params))
    return gain >= q * max(1.0, chi2_big / max(dof_big, 1))


def _stepwise(
    p: _Problem, s: Structure, theta: np.ndarray, keep: tuple[str, ...] = ()
) -> tuple[Structure, np.ndarray, np.ndarray, float]:
    """Drop the linear terms the others can do without (chi2 gain < 3.84, F test)."""
    theta, c, chi2 = fit_structure(p, s, theta, None)
    while True:
        names = s.names()
        zero = [k for k, v in zip(names, c) if v <= 0 and k in s.linear and k not in keep]
        if zero:  # terms at 0 leave without a test
            s = replace(s, linear=tuple(k for k in s.linear if k not in zero))
            theta, c, chi2 = fit_structure(p, s, theta, None, rounds=1)
            continue
        active = [k for k, v in zip(names, c) if v > 0 and k in s.linear and k not in keep]
        dof = residual_dof(p, c, theta)
        if len(active) + len(keep) <= 1:
            return s, theta, c, chi2
        best = None
        for k in active:
            s2 = replace(s, linear=tuple(x for x in s.linear if x != k))
            _, chi2b, _ = p.solve(s2, theta)
            if best is None or chi2b < best[1]:
                best = (s2, chi2b)
        if best is None or _test(best[1] - chi2, chi2, dof, 1):
            return s, theta, c, chi2
        # judged under the weights of the model with it; refitted under its own, the
        # model without it may fit far worse (a long-tau rise then has the small sd of
        # a white line): the term stays when the refit shows it needed beyond doubt
        # (the 99.9 % point: a marginal term's fate does not hang on whose weights judged it)
        old = (s, theta, c, chi2)
        s = best[0]
        theta, c, chi2 = fit_structure(p, s, theta, None, rounds=1)
        if chi2 - old[3] >= CHI2_1_999 * max(1.0, old[3] / dof):
            fit_structure(p, old[0], old[1], None, rounds=1)  # its weights back
            return old


def _extend(
    p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, chi2: float, lin: tuple[str, ...]
) -> tuple[Structure, np.ndarray, np.ndarray, float]:
    """Band limit, then Gauss-Markov processes, each kept only when the data need it."""
    # every allowed term again (a misfit short end may have pushed some out), but Q:
    # a quantization's rise and a filter's bend would only trade against each other
    base_lin = tuple(k for k in lin if k != "Q")
    cands = []
    for shape, order in LP_FORMS:
        s2 = Structure(base_lin, order, 0, shape=shape)
        newer = shape == "pole" and order not in CLASSIC_POLES  # leaves the weights as it found them
        saved = p.kept() if newer else None
        th, c2, chi2b = fit_structure(p, s2, np.array([math.log(0.25 * p.fs)]), 0)
        cands.append((chi2b, s2, th, c2))
        if saved is not None:
            p.restore(saved)
    chi2b, s2, th, c2 = _lp_form(p, cands)
    dof = max(p.t.size - int(np.sum(c2 > 0)) - 1, 1)
    # its gain is judged against white N with the same terms: the terms let in again
    # must not pass their own gain off as the band limit's
    chi2w = fit_structure(p, Structure(base_lin), np.zeros(0), None)[2]
    if c2[s2.names().index("N")] > 0 and _lp_shows(p, s2, th, c2) and _test(min(chi2, chi2w) - chi2b, chi2b, dof, 1):
        s, theta, c, chi2 = _stepwise(p, s2, th, keep=("N",))
    for _j in range(MAX_GM):
        s2 = Structure(tuple(k for k in lin if k in s.linear or k in ("B", "K", "R")), s.lp, s.ngm + 1, shape=s.shape)
        if p.t.size - (len(s2.linear) + s2.ngm + len(s2.nonlinear())) < 2:
            break
        # its gain is judged against the same terms without it: the terms let in again
        # beside it (a stepwise drop may have left one out by a hair) must not pass their
        # gain off as the GM's (a rate random walk read as a ramp plus a GM of T beyond the record)
        s0 = replace(s2, ngm=s.ngm)
        chi2_0 = chi2 if s0 == s else fit_structure(p, s0, theta, None, rounds=1)[2]
        th0 = np.concatenate((theta, [math.log(p.t[p.t.size // 2])]))
        th, c2, chi2b = fit_structure(p, s2, th0, th0.size - 1)
        dof = residual_dof(p, c2, th)
        if c2[-1] > 0 and _test(min(chi2, chi2_0) - chi2b, chi2b, dof, 2) and _gm_visible(p, s2, th, c2):
            s, theta, c, chi2 = _stepwise(p, s2, th, keep=("N",))
        elif (
            not s.ngm
            and c2[-1] > 0
            and _gm_visible(p, s2, th, c2)
            and (alt := _gm_in_place(p, s2, th, chi2, s, theta, c))
        ):
            s, theta, c, chi2 = alt
        else:
            break
    if p.sine_on:
        s, theta, c, chi2 = _try_sine(p, s, theta, c, chi2)
    if s.lp and not p.floor.any():
        s, theta, c, chi2 = _try_res(p, s, theta, c, chi2)
    elif s.lp:  # under a model error: the one the model with a resonance needs
        s, theta, c, chi2 = _res_own_error(p, s, theta, c, chi2)
    return s, theta, c, chi2


def _gm_in_place(
    p: _Problem, s2: Structure, th: np.ndarray, chi2: float, s: Structure, theta: np.ndarray, c: np.ndarray
) -> tuple[Structure, np.ndarray, np.ndarray, float] | None:
    """The Gauss-Markov process of s2 in place of the rise of s (K or a ramp) and of the terms
    it makes needless, kept when that structure, under its own weights, beats s by the
    information criterion: a hump that flicker and a walk together mimic (beside them the
    process adds little; in their place it fits better).  Not kept with a rise left beside it
    (it would only bend a walk's line: a walk read as a ramp plus a long process), nor where
    s has no rise (beside flicker alone it would only bend B's floor: a real gyro's N moved 4 %),
    nor with its ADEV peak (1.89 T) within RISE_OCTAVES of the last tau: there it is K's rival
    for a rise (_rise_as_k), and a curve flat to its end (the shared unit's accelerometers from
    300 s on) would be given to it."""
    if not any(k in ("K", "R") and v > 0 for k, v in zip(s.names(), c)):
        return None
    saved = p.kept()
    s3, th3, c3, chi3 = _stepwise(p, s2, th, keep=("N",))
    rise = [k for k, v in zip(s3.names(), c3) if k in ("K", "R") and v > 0]
    if s3.ngm == s2.ngm and c3[-1] > 0 and not rise and s3.ngm - 1 not in _rivals(p, s3, th3, c3)[1]:
        if chi3 + 2 * (np.sum(c3 > 0) + th3.size) < chi2 + 2 * (np.sum(c > 0) + theta.size):
            return s3, th3, c3, chi3
    p.restore(saved)
    return None


def _lp_form(p: _Problem, cands: list[tuple]) -> tuple:
    """The band limit's form: the better pole (RC or Butterworth), or where the pole is
    pinned at its ceiling (a bend that needs a cutoff point samples cannot show) the RC
    averaged over each sample; another form only where it fits decisively better (a 95 %
    F test with one degree of freedom): on a curve that cannot tell them apart, the
    classic form."""
    classic = [x for x in cands if x[1].shape == "pole" and x[1].lp in CLASSIC_POLES]
    pole = min(classic, key=lambda x: x[0])
    first = pole
    if _pinned(pole[1], pole[2], p.fs):
        first = next((x for x in cands if x[1].shape == "pole_mean" and not _pinned(x[1], x[2], p.fs)), pole)
    others = [x for x in cands if x is not first and not any(x is y for y in classic)]
    alt = min(others, key=lambda x: x[0], default=None)
    if alt is None:
        return first
    dof = max(p.t.size - int(np.sum(alt[3] > 0)) - 1, 1)
    return alt if _test(first[0] - alt[0], alt[0], dof, 1) else first


def _try_sine(
    p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, chi2: float
) -> tuple[Structure, np.ndarray, np.ndarray, float]:
    """A sinusoid, kept when it lowers chi2 by the 95 % point of chi2(2) and is a fifth
    of the model somewhere."""
    if not s.sine and p.t.size - (len(s.linear) + s.ngm + len(s.nonlinear()) + 2) >= 2:
        s2 = replace(s, sine=1)
        # the robust weights of the model without it have set its hump aside: the
        # sinusoid is judged with weights of its own
        saved, mod = p.robust, columns(s, theta, p.m, p.fs) @ c
        p.robust = np.ones(p.t.size)
        p.set_reference(mod)
        th0 = _sine_start(p, s, theta, c, s2)
        th, c2, chi2b = fit_structure(p, s2, th0, None)
        dof = residual_dof(p, c2, th)
        if c2[-1] > 0 and _test(chi2 - chi2b, chi2b, dof, 2) and _gm_visible(p, s2, th, c2, 0.2):
            return _stepwise(p, s2, th, keep=("N",))
        p.robust = saved
        p.set_reference(mod)
    return s, theta, c, chi2


def _res_grid(p: _Problem, s: Structure, theta: np.ndarray) -> np.ndarray:
    """The parameters of s with a resonance added, its frequency and quality the best of a grid."""
    s2 = replace(s, res=1)
    i = s2.res_at()
    (f_lo, f_hi), (q_lo, q_hi) = bounds(s2, p.t, p.fs)[i : i + 2]
    best = (math.inf, theta)
    for f in np.linspace(f_lo, f_hi, 9):
        for q in np.linspace(q_lo, q_hi, 4):
            th = np.concatenate((theta[:i], [f, q], theta[i:]))
            v = p.solve(s2, th)[1]
            if v < best[0]:
                best = (v, th)
    return best[1]


def _try_res(
    p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, chi2: float, start=None
) -> tuple[Structure, np.ndarray, np.ndarray, float]:
    """A resonance (resonance.py) on the first taus, kept when it lowers chi2 by the 95 %
    point of chi2(3), is RES_SHARE of the model somewhere and the model with it fits within
    chance (on the whole curve or where it lives; under a model error through _res_own_error)."""
    if s.res or p.t.size - (len(s.linear) + s.ngm + len(s.nonlinear()) + 3) < 2:
        return s, theta, c, chi2
    s2 = replace(s, res=1)
    saved = p.ref.copy()  # the weights as they were, exactly, where it is not kept
    th, c2, chi2b = fit_structure(p, s2, _res_grid(p, s, theta) if start is None else start, None)
    dof = residual_dof(p, c2, th)
    k = s2.names().index("RES")
    seen = _shows(p, s2, th, c2, k, RES_SHARE)
    # resolved only where the model with it fits within chance: under a model error its bump and the
    # band limit's bend trade (on real gyros and accelerometers it moved N by -7 to +3 %); on the whole
    # curve, or where it lives (curve.local_floor on the points' chance variances: lines at long
    # taus are no reason to set aside a resonance the short taus show beyond doubt)
    A2 = columns(s2, th, p.m, p.fs)
    lives = A2[:, k] * c2[k] >= RES_SHARE * (A2 @ c2)
    fits = not misfits(chi2b, dof) or not local_floor(p, A2 @ c2, dof)[lives].any()
    if c2[k] > 0 and _test(chi2 - chi2b, chi2b, dof, 3) and seen and fits and _res_pinned(p, s2, th, c2):
        return _stepwise(p, s2, th, keep=("N",))
    p.set_reference(saved)
    return s, theta, c, chi2


def _res_own_error(
    p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, chi2: float
) -> tuple[Structure, np.ndarray, np.ndarray, float]:
    """The resonance tried under the model error the model with it needs (set_floor, by tau
    region): the error of the first model, granted on the short taus because it lacked the
    resonance, would hide it there.  Fitted under the present weights, the model with it
    sets the error; the structure without it is refitted under that error and _try_res
    judges it (p's error and weights restored where it is not kept)."""
    if s.res or p.t.size - (len(s.linear) + s.ngm + len(s.nonlinear()) + 3) < 2:
        return s, theta, c, chi2
    saved = p.floor.copy(), p.ref.copy(), p.robust.copy()
    s2 = replace(s, res=1)
    th2, c2, _ = fit_structure(p, s2, _res_grid(p, s, theta), None, rounds=1)
    set_floor(p, s2, th2, c2, residual_dof(p, c2, th2))
    th1, c1, chi1 = fit_structure(p, s, theta, None, rounds=1)
    r = _try_res(p, s, th1, c1, chi1, start=th2)
    if r[0].res:
        return r
    p.floor, p.ref, p.robust = saved
    p.set_reference(p.ref)
    return s, theta, c, chi2


def _res_pinned(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray) -> bool:
    """The resonance's variance pinned by the curve: clear of 0 by 1.96 sd (the rule by which
    the result gives a term a value rather than a bound; curve.covariance, its quality or
    frequency held where the search's bound holds it).  One the curve does not pin trades
    with the band limit's bend and with N while claiming a mode it cannot describe."""
    k = s.names().index("RES")
    sd_c, _ = covariance(p, s, theta, c, p.gls.white(columns(s, theta, p.m, p.fs)), 1.0)
    return bool(c[k] > Z95 * sd_c[k])


RES_SHARE = 0.05
"""A resonance is kept where it is at least this share of the model's AVAR at some tau."""


def _sine_start(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, s2: Structure) -> np.ndarray:
    """Parameters to start a sinusoid from: its frequency put where the present model
    leaves the largest hump (ADEV peak at 0.371 / f0, and half and twice that), or on a
    grid of the measured taus, whichever fits best (a sinusoid's hump is an octave wide:
    a coarse grid alone misses it)."""
    r = p.y / (columns(s, theta, p.m, p.fs) @ c)
    peaks = [i for i in range(1, r.size - 1) if r[i] > 1.0 and r[i] >= r[i - 1] and r[i] >= r[i + 1]]
    lo, hi = bounds(s2, p.t, p.fs)[-1]
    cands = [math.log(0.371 / (p.t[i] * k)) for i in peaks for k in (0.7, 1.0, 1.4)]
    cands += list(np.linspace(lo, hi, 17))
    best = (math.inf, None)
    for g in cands:
        if lo <= g <= hi:
            th = np.concatenate((theta, [g]))
            v = p.solve(s2, th)[1]
            if v < best[0]:
                best = (v, th)
    return best[1] if best[1] is not None else np.concatenate((theta, [0.5 * (lo + hi)]))


def _lp_shows(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray) -> bool:
    """A band limit is kept only where the curve can show it: its cutoff below
    LP_FC_MAX fs (the search's ceiling is 0.49 fs: a fit pinned there asks for less
    bend than any low-pass of the catalogue gives) and its bend (the low-passed
    column under white N's) at least LP_BEND on two octave points or more.  A bend
    of the first point alone is that point's scatter: a two-pole low-pass above
    ~0.4 fs lowers only the first octave (by 4 % at 0.49 fs, under 1 % the next)."""
    if _pinned(s, theta, p.fs):
        return False
    white = columns(Structure(("N",)), np.zeros(0), p.m, p.fs)[:, 0]
    lp = columns(Structure(("N",), s.lp, shape=s.shape), theta[:1], p.m, p.fs)[:, 0]
    return int(np.sum(lp <= (1.0 - LP_BEND) * white)) >= 2


LP_FC_MAX = 0.45
LP_BEND = 0.02


def _pinned(s: Structure, theta: np.ndarray, fs: float) -> bool:
    """The band limit's cutoff at its form's ceiling: LP_FC_MAX fs for the point-sampled
    forms, as far under their search's ceiling for the others (processes.FC_CEILING)."""
    return math.exp(theta[0]) >= LP_FC_MAX / FC_CEILING["pole"] * FC_CEILING[s.shape] * fs


def _gm_visible(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, share: float = 0.5) -> bool:
    """A new Gauss-Markov process is kept only with white noise beside it and where
    it is at least half of the model somewhere (its hump shows): else it only
    stands in for the band limit or the white noise."""
    names = s.names()
    if "N" not in names or c[names.index("N")] <= 0:
        return False
    return _shows(p, s, theta, c, -1, share)


def _shows(p: _Problem, s: Structure, theta: np.ndarray, c: np.ndarray, k: int, share: float) -> bool:
    """Term k is at least ``share`` of the model's AVAR at some tau."""
    A = columns(s, theta, p.m, p.fs)
    return bool(np.any(A[:, k] * c[k] >= share * (A @ c)))
