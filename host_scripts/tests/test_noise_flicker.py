"""Flicker rate noise at the sample rate: the catalogue's AVAR is that of a 1/f PSD
sampled up to Nyquist (not only IEEE 952's constant), graded by what it did not
make: the frequency-domain integral done here with scipy's quad, a 1/f stream
shaped in frequency here with numpy alone (the textbook method: white noise's
FFT times sqrt(PSD)), and a heavily low-passed stream where the first octaves
decide B."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, signal

from imu_allan import api
from imu_allan.noise import Flicker
from imu_allan.stats import allan

FS = 100.0
IEEE = 2.0 * math.log(2.0) / math.pi  # IEEE 952: flicker's AVAR B^2 (2 ln 2 / pi), ADEV 0.664 B


def _avar_by_quad(m: int, fs: float, b: float) -> float:
    """Half the variance of the difference of adjacent m-sample means of samples whose
    one-sided PSD is b^2 / (pi f) on (0, fs/2]: the transfer |(1/m) sum e^{-i w j}|^2
    |1 - e^{-i w m}|^2 integrated against the PSD, one quad per lobe of the integrand."""

    def integrand(f: float) -> float:
        w = 2.0 * math.pi * f / fs
        mean = (math.sin(w * m / 2.0) / (m * math.sin(w / 2.0))) ** 2
        diff = 4.0 * math.sin(w * m / 2.0) ** 2
        return 0.5 * b * b / (math.pi * f) * mean * diff

    edges = np.linspace(0.0, fs / 2.0, m + 1)
    return sum(integrate.quad(integrand, lo, hi, limit=200)[0] for lo, hi in zip(edges[:-1], edges[1:]))


def _textbook_flicker(rng: np.random.Generator, n: int, fs: float, b: float) -> np.ndarray:
    """White noise shaped in frequency to the one-sided PSD b^2 / (pi f) (unit white: 2 / fs)."""
    size = 1 << int(math.ceil(math.log2(2 * n)))
    spectrum = np.fft.rfft(rng.standard_normal(size))
    f = np.fft.rfftfreq(size, 1.0 / fs)
    gain = np.zeros_like(f)
    gain[1:] = np.sqrt(b * b / (math.pi * f[1:]) * fs / 2.0)
    return np.fft.irfft(spectrum * gain, size)[:n]


@pytest.mark.parametrize("m", [1, 2, 3, 5, 16, 100, 1000])
def test_flicker_avar_is_the_sampled_one_over_f_psd(m: int) -> None:
    want = _avar_by_quad(m, FS, 2.0)
    assert Flicker(2.0).avar(np.array([m]), FS)[0] == pytest.approx(want, rel=5e-5)


def test_flicker_avar_reaches_the_ieee_constant_and_exceeds_it_at_the_first_octaves() -> None:
    avar = Flicker(1.0).avar(np.array([1, 2, 4, 4096]), FS)
    assert avar[3] == pytest.approx(IEEE, rel=1e-5)
    assert avar[0] / IEEE > 1.15 and avar[1] / IEEE > 1.05 and avar[2] / IEEE > 1.02


def test_a_textbook_flicker_stream_follows_the_catalogue_not_the_constant() -> None:
    n = 1 << 20
    ratios = []
    for seed in range(4):
        x = _textbook_flicker(np.random.default_rng(seed), n, FS, 1.0)
        r = allan.octave_oavar(x)
        ratios.append(r.oavar[:3, 0] / Flicker(1.0).avar(r.ms[:3], FS))
    got = np.mean(ratios, axis=0)
    # the first octaves of 2^20 samples: a few thousand degrees of freedom a seed even for 1/f
    assert np.all(np.abs(got - 1.0) < 0.02), got
    const = np.mean(ratios, axis=0) * Flicker(1.0).avar(np.array([1, 2, 4]), FS) / IEEE
    assert const[0] > 1.12, const  # the IEEE constant alone is 19 % under the stream at m = 1


def test_the_catalogue_bank_follows_its_own_avar_at_every_octave() -> None:
    x = Flicker(1.0).simulate(1 << 20, FS, 5)
    r = allan.octave_oavar(x)
    theory = Flicker(1.0).avar(r.ms, FS)
    ratio = r.oavar[:, 0] / theory
    tau = r.ms / FS
    assert np.all(np.abs(ratio[tau <= 0.08] - 1) < 0.03), ratio
    assert np.all(np.abs(ratio[(tau > 0.08) & (tau <= 1)] - 1) < 0.05), ratio


@pytest.mark.parametrize("fc", [1.0, 5.0])
def test_B_through_a_two_pole_low_pass_is_read_from_the_sampled_form(fc: float) -> None:
    """White noise through a 2-pole Butterworth at fs/100 or fs/20 leaves the first octaves
    to the flicker: the constant read B 6-11 % high there with a 3 % interval that missed it."""
    n, white, b = 1 << 20, 0.003, 0.003 / (0.664 * math.sqrt((1 << 20) / FS / 200))
    rng = np.random.default_rng(int(fc))
    sos = signal.butter(2, fc, fs=FS, output="sos")
    x = signal.sosfilt(sos, rng.standard_normal(n) * white * math.sqrt(FS)) + _textbook_flicker(rng, n, FS, b)
    t = api.noise_terms(x, FS).terms["B"]
    assert t.value is not None and abs(t.value / b - 1) < 0.1, t
    assert t.low <= b <= t.high, t


def test_flicker_read_as_means_is_the_ieee_constant_and_its_simulation_follows() -> None:
    """A part that averages sees a continuous 1/f through each sample's mean: the constant at
    every m, checked on a textbook stream at 8x the rate averaged here, and on the bank."""
    m = np.array([1, 2, 4, 16])
    assert np.allclose(Flicker(1.0, "mean").avar(m, FS), IEEE, rtol=1e-12)
    fast = _textbook_flicker(np.random.default_rng(9), 8 << 18, 8 * FS, 1.0)
    means = fast.reshape(-1, 8).mean(axis=1)
    got = allan.octave_oavar(means).oavar[:3, 0] / IEEE
    assert np.all(np.abs(got - 1) < 0.03), got
    bank = allan.octave_oavar(Flicker(1.0, "mean").simulate(1 << 18, FS, 3))
    assert np.all(np.abs(bank.oavar[:4, 0] / IEEE - 1) < 0.03), bank.oavar[:4, 0] / IEEE
