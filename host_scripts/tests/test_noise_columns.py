"""The one-pole Allan variances the fit's columns come from (an RC or a Gauss-Markov's real
pole, a resonance's complex one, the RC averaged over each sample) against forms computed
another way: the definition summed term by term from the autocovariance, and IEEE 952's
continuous exponentially correlated noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_allan.noise.processes import AR1, LP
from imu_allan.noise.resonance import Resonance

FS = 100.0
M = np.array([1.0, 2.0, 3.0, 4.0, 8.0, 16.0, 37.0, 64.0])


def _avar_by_sums(r0: float, r, m: np.ndarray) -> np.ndarray:
    """AVAR(m) = (4 S(m) - S(2m)) / (2 m^2), S(n) = n r0 + 2 sum_{k<n} (n - k) r(k), summed."""

    def S(n: int) -> float:
        k = np.arange(1, n)
        return n * r0 + 2.0 * float(np.sum((n - k) * r(k)))

    return np.array([(4.0 * S(int(n)) - S(2 * int(n))) / (2.0 * n * n) for n in m])


@pytest.mark.parametrize("T", [0.02, 0.3, 5.0])
def test_a_gauss_markov_column_is_its_summed_definition(T):
    sigma = 1.5
    a = math.exp(-1.0 / (FS * T))
    want = _avar_by_sums(sigma**2, lambda k: sigma**2 * a**k, M)
    assert np.allclose(AR1(sigma, T).avar(M, FS), want, rtol=1e-9)


@pytest.mark.parametrize("f0, T", [(12.0, 0.2), (31.0, 1.0), (45.0, 0.05)])
def test_a_resonance_column_is_its_summed_definition(f0, T):
    sigma = 0.7
    p = math.exp(-1.0 / (FS * T)) * np.exp(2j * math.pi * f0 / FS)
    want = _avar_by_sums(sigma**2, lambda k: sigma**2 * np.real(p**k), M)
    assert np.allclose(Resonance(sigma, f0, T).avar(M, FS), want, rtol=1e-9, atol=1e-12 * sigma**2)


@pytest.mark.parametrize("fc", [0.5, 7.0, 60.0, 300.0])
def test_an_rc_averaged_over_each_sample_is_ieee_exponentially_correlated_noise(fc):
    # unit low-frequency density: R(t) = (wc / 2) exp(-wc |t|), whose integral is 1; IEEE 952
    # annex C: AVAR = q Tc^2 / tau^2 (2 tau / Tc - 3 + 4 e^(-tau / Tc) - e^(-2 tau / Tc)), q = R(0)
    wc = 2.0 * math.pi * fc
    tau, Tc = M / FS, 1.0 / wc
    want = (wc / 2.0) * Tc**2 / tau**2 * (2.0 * tau / Tc - 3.0 + 4.0 * np.exp(-tau / Tc) - np.exp(-2.0 * tau / Tc))
    assert np.allclose(LP(1.0, fc, 1, "pole_mean").avar(M, FS), want, rtol=1e-7)


@pytest.mark.parametrize("fc", [0.5, 4.0, 20.0, 45.0])
def test_a_four_pole_band_limit_is_its_summed_definition_through_scipys_butterworth(fc):
    """White noise of low-frequency density N through scipy.signal.butter(4, fc): its autocovariance
    from the filter's impulse response (summed to where it has died out), the Allan variance summed."""
    from scipy import signal

    b, a = signal.butter(4, fc, fs=FS)
    h = signal.lfilter(b, a, np.r_[1.0, np.zeros(int(200 * FS / fc))])
    var_in = FS / (np.sum(b) / np.sum(a)) ** 2  # unit density: variance fs per sample at unit DC gain
    r = np.correlate(h, h, "full")[h.size - 1 :] * var_in
    want = _avar_by_sums(r[0], lambda k: r[k], M)
    assert np.allclose(LP(1.0, fc, 4).avar(M, FS), want, rtol=1e-8)
