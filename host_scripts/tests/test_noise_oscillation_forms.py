"""Whether a curve shows an oscillation's hump is judged on the first model and on it without
its Gauss-Markov processes (a GM may stand in for the hump).  That second form must keep the
parameters that follow the GMs' times in theta: a resonance's frequency and quality (the
structure of a real accelerometer with a knock left in: a band limit, a GM and a mount mode),
a sinusoid's frequency."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_allan.noise.curve import Structure, _Problem, columns
from imu_allan.noise.select import _shows_oscillation, _without_gms
from imu_allan.stats import edf

FS = 100.0
MS = 2.0 ** np.arange(19)
TAU = MS / FS
N_WHITE = 0.1


def _theta(s: Structure) -> np.ndarray:
    """Log parameters in s.nonlinear()'s order: fc 30 Hz, T 5 s and 60 s, a 9.9 Hz mode of
    quality 10, a 0.02 Hz sinusoid."""
    values = {"fc": 30.0, "T1": 5.0, "T2": 60.0, "f_res": 9.9, "q_res": 10.0, "f0": 0.02}
    return np.log([values[k] for k in s.nonlinear()])


@pytest.mark.parametrize("ngm", [1, 2])
@pytest.mark.parametrize("lp,res,sine", [(0, 1, 0), (1, 1, 0), (0, 0, 1), (2, 1, 1), (1, 0, 0)])
def test_the_form_without_gms_has_the_other_columns_of_the_structure(ngm: int, lp: int, res: int, sine: int) -> None:
    s = Structure(("N", "B", "K"), lp=lp, ngm=ngm, res=res, sine=sine)
    theta = _theta(s)
    gm_cols = [j for j, name in enumerate(s.names()) if name.startswith("GM")]
    want = np.delete(columns(s, theta, MS, FS), gm_cols, axis=1)
    s0, th0 = _without_gms(s, theta)
    assert s0.ngm == 0 and th0.size == theta.size - ngm
    np.testing.assert_array_equal(columns(s0, th0, MS, FS), want)


def _gm_avar(sigma: float, t_c: float, tau: np.ndarray) -> np.ndarray:
    """A first-order Gauss-Markov process's Allan variance (IEEE 952 annex C; variance sigma^2,
    correlation time t_c): (sigma t_c / tau)^2 (2 tau / t_c - 3 + 4 e^(-tau/t_c) - e^(-2 tau/t_c))."""
    r = tau / t_c
    return (sigma * t_c / tau) ** 2 * (2 * r - 3 + 4 * np.exp(-r) - np.exp(-2 * r))


@pytest.mark.parametrize("lp", [0, 1])
def test_a_hump_a_gm_stands_in_for_is_seen_beside_a_resonance(lp: int) -> None:
    """White noise plus a GM (T 10 s) by the textbook formulas: the structure holding that GM
    and a resonance fits the curve, without the GM the hump is left; white noise alone shows none."""
    efn = edf.edf_function(MS.astype(np.int64), np.full(MS.size, (1 << 20) + 1), np.ones(MS.size, dtype=np.int64))
    s = Structure(("N",), lp=lp, ngm=1, res=1)
    theta = np.log(([40.0] if lp else []) + [10.0, 9.9, 10.0])
    white = N_WHITE**2 / TAU
    hump = white + _gm_avar(0.03, 10.0, TAU)
    assert _shows_oscillation(_Problem(TAU, hump, FS, efn, "overlapping"), s, theta)
    assert not _shows_oscillation(_Problem(TAU, white, FS, efn, "overlapping"), s, theta)
    assert math.isclose(float(_gm_avar(0.03, 10.0, np.array([1e4]))[0]), 2 * 0.03**2 * 10.0 / 1e4, rel_tol=2e-3)
