"""The whole-curve noise fit, graded on streams it did not make.

Two generators: the catalogue's own simulators (imu_allan.noise) and an
independent one written here from the textbook formulas: Gaussian white
noise through scipy.signal.lfilter with Butterworth coefficients
(scipy.signal.butter) or a cascade of sampled RC poles, a cumulative sum for
the rate random walk, Kasdin's fractional differencing for flicker (N. J.
Kasdin, Proc. IEEE 83, 1995: h_k = h_{k-1} (k - 1 + alpha/2) / k, innovation
variance B^2 for a one-sided PSD B^2 / (pi f)) and the AR(1) recursion for a
Gauss-Markov process.  The truth is known: N (the white level at low
frequency), B, K, T."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from imu_allan import api
from imu_allan.noise import AR1, LP, RW, Flicker, Model

FS = 1000.0
N_TRUE = 0.01
B_TRUE = 0.006  # floor 0.664 B = 0.004: above the white line beyond ~6 s
K_TRUE = 8e-4  # crosses the white line near 20 s
GM_SIGMA, GM_T = 0.03, 2.0


def _independent(n: int, seed: int, order: int, fc: float, extra: str) -> np.ndarray:
    rng = np.random.default_rng(seed)
    w = rng.standard_normal(n) * N_TRUE * math.sqrt(FS)
    if order == 1:
        b, a = signal.butter(1, fc, fs=FS)
    elif order == 2:
        b, a = signal.butter(2, fc, fs=FS)
    else:  # two sampled RC poles in cascade (critically damped, not a Butterworth)
        p = math.exp(-2 * math.pi * fc / FS)
        b, a = [(1 - p) ** 2], [1.0, -2 * p, p * p]
    x = signal.lfilter(b, a, w)[:n]  # unit DC gain: the low-frequency density stays N^2
    if extra == "flicker":
        k = np.arange(1, n)
        h = np.concatenate(([1.0], np.cumprod((k - 1 + 0.5) / k)))
        e = rng.standard_normal(n) * B_TRUE
        x = x + signal.fftconvolve(e, h)[:n]
    elif extra == "rrw":
        x = x + np.cumsum(rng.standard_normal(n) * K_TRUE / math.sqrt(FS))
    elif extra == "gm":
        phi = math.exp(-1.0 / (FS * GM_T))
        v = rng.standard_normal(n) * GM_SIGMA * math.sqrt(1 - phi * phi)
        x = x + signal.lfilter([1.0], [1.0, -phi], v, zi=[phi * GM_SIGMA * rng.standard_normal()])[0]
    return x


def _catalogue(n: int, seed: int, order: int, fc: float, extra: str) -> np.ndarray:
    m = Model([LP(N_TRUE, fc, min(order, 2))])
    m = m + {"none": Model(), "flicker": Flicker(B_TRUE), "rrw": RW(K_TRUE), "gm": AR1(GM_SIGMA, GM_T)}[extra]
    return m.simulate(n, FS, seed)


def _check(fit, extra: str) -> None:
    t = fit.terms
    assert t["N"].value is not None, fit.notes
    assert abs(t["N"].value / N_TRUE - 1) < 0.10, (t["N"].value, fit.fitted)
    assert t["Q"].value is None, fit.fitted  # a low-pass never looks like quantization
    if extra == "flicker":
        b = t["B"].value
        if b is None:  # a bank of slow GM processes may stand in for the 1/f floor: read it off
            b = math.sqrt(fit.model(np.array([20.0]))[0] - N_TRUE**2 / 20.0) / math.sqrt(2 * math.log(2) / math.pi)
        assert abs(b / B_TRUE - 1) < 0.35, (b, fit.fitted)
    if extra == "rrw":
        assert t["K"].value is not None and abs(t["K"].value / K_TRUE - 1) < 0.35, fit.fitted
    if extra == "gm":
        gms = [v for k, v in t.items() if k.startswith("GM")]
        assert gms, fit.fitted
        T = max(gms, key=lambda g: g.value or 0).extra["tau_c"]
        assert GM_T / 2 < T < GM_T * 2, fit.fitted


CASES = [
    (1, FS / 100, "none"),
    (1, FS / 20, "none"),
    (1, FS / 4, "none"),
    (2, FS / 100, "none"),
    (2, FS / 20, "none"),
    (2, FS / 4, "none"),
    (1, FS / 20, "flicker"),
    (2, FS / 100, "rrw"),
    (2, FS / 20, "gm"),
    (1, FS / 4, "gm"),
    (2, FS / 4, "flicker"),
    (1, FS / 100, "rrw"),
]


@pytest.mark.parametrize("order,fc,extra", CASES)
def test_fit_recovers_lowpassed_white_noise_from_an_independent_generator(order, fc, extra) -> None:
    x = _independent(1 << 19, 11, order, fc, extra)
    _check(api.noise_terms(x, FS), extra)


@pytest.mark.parametrize(
    "fc,extra",
    [
        (FS / 20, "none"),
        (FS / 4, "gm"),
        # the walk's realization runs 3.5-4.5x above its K line over its four longest octaves,
        # and the two RC poles (not a catalogue band limit) make the fit grant a model error
        (FS / 4, "rrw"),
    ],
)
def test_fit_recovers_two_rc_poles_in_cascade(fc, extra) -> None:
    x = _independent(1 << 19, 5, 3, fc, extra)
    _check(api.noise_terms(x, FS), extra)


@pytest.mark.parametrize("order", (1, 2))
def test_a_rate_random_walk_rising_at_the_records_end_is_read_as_K(order) -> None:
    """IEEE 952 reads a +1/2 slope as K.  K = 8e-4 crosses N's line at 22 s of a 524 s
    record: the walk rules only the last four octaves, of few degrees of freedom, where a
    realization may run well above or below K's line and carries a trend of its own.  On
    eight streams the rise is never given to a ramp, a Gauss-Markov process or a sinusoid;
    K's 95 % interval (or its bound) holds the truth on seven or more (a 95 % interval does
    so with probability 0.94; on the one stream missed here the curve runs at 0.46-0.67 of
    the true one over its last three octaves, where flicker is read) and K is within 35 %
    on five or more."""
    near, held, rivals = 0, 0, []
    for seed in range(8):
        fit = api.noise_terms(_independent(1 << 19, seed, order, FS / 4, "rrw"), FS)
        t = fit.terms
        k = t["K"]
        near += k.value is not None and abs(k.value / K_TRUE - 1) < 0.35
        held += (k.low if k.value else 0.0) <= K_TRUE <= (k.high if k.value else k.upper)
        if t["R"].value is not None or any(n.startswith(("GM", "SIN")) for n in t):
            rivals.append((seed, fit.fitted))
    assert not rivals
    assert held >= 7, held
    assert near >= 5, near


@pytest.mark.parametrize("order,fc,extra", CASES[::2])
def test_fit_recovers_the_catalogues_own_streams(order, fc, extra) -> None:
    x = _catalogue(1 << 19, 7, order, fc, extra)
    _check(api.noise_terms(x, FS), extra)


def test_plain_white_noise_gets_no_band_limit_and_no_gauss_markov() -> None:
    x = np.random.default_rng(3).standard_normal(1 << 19) * N_TRUE * math.sqrt(FS)
    fit = api.noise_terms(x, FS)
    assert abs(fit.terms["N"].value / N_TRUE - 1) < 0.05
    assert set(fit.terms) == {"Q", "N", "B", "K", "R"}, fit.fitted


# Six channels as a 10-bit ADC gives them at 1 kHz: white noise of a few counts,
# rounded to codes, with a little rate random walk or flicker, from numpy alone:
# the textbook white sequence, its cumulative sum, Kasdin's flicker filter by FFT
# convolution.  Plain white noise: no band limit, N the white level with the
# rounding's 1/12 code^2 (exact to 1e-6 from 0.85 counts up wherever the signal
# sits between codes; below, it depends on where: hence no finer channel here).
WHITE_COUNTS = (2.0, 2.5, 1.7, 0.85, 1.0, 1.2)


def _adc_channel(rng: np.random.Generator, n: int, white: float, extra: str) -> np.ndarray:
    x = 512.0 + rng.standard_normal(n) * white
    n_true = white / math.sqrt(FS)
    if extra == "rrw":  # K = N / 5: above N's line beyond ~9 s
        x = x + np.cumsum(rng.standard_normal(n)) * (n_true / 5.0) / math.sqrt(FS)
    else:  # flicker of B = N / 3 (Kasdin, innovation sd B as above): its floor under N's line
        k = np.arange(1, n)
        h = np.concatenate(([1.0], np.cumprod((k - 0.5) / k)))
        e = rng.standard_normal(n) * n_true / 3.0
        m = 1 << int(math.ceil(math.log2(2 * n)))
        x = x + np.fft.irfft(np.fft.rfft(e, m) * np.fft.rfft(h, m), m)[:n]
    return np.round(x)


@pytest.mark.parametrize(
    "n,seed,extra",
    [(n, 1, e) for n in (20000, 50000, 200000) for e in ("rrw", "flicker")]
    # two streams where the second, robust selection went astray (dropped K, collapsed N):
    # a chi2/dof above 1 by chance taken for model error (it runs now only on a misfit), and
    # a model leaving most points far off had them all capped
    + [(20000, 2, "flicker"), (200000, 0, "rrw")],
)
def test_plain_white_noise_at_1khz_is_read_as_white_with_no_band_limit_near_nyquist(n, seed, extra) -> None:
    """N on every channel within 10 %, its 95 % interval holding the truth on 5 of 6
    channels at least (all six only 74 % of the time), no band limit near Nyquist."""
    rng = np.random.default_rng(seed)
    misses = []
    for white in WHITE_COUNTS:
        truth = math.sqrt((white**2 + 1 / 12) / FS)
        fit = api.noise_terms(_adc_channel(rng, n, white, extra), FS)
        t = fit.terms["N"]
        assert t.value is not None, (white, fit.fitted, t.note)
        assert abs(t.value / truth - 1) < 0.10, (white, t.value, truth, fit.fitted)
        if not t.low <= truth <= t.high:
            misses.append((white, t.low, t.high, truth, fit.fitted))
        lp = fit.terms.get("LP")
        assert lp is None or lp.extra["fc"] < 0.45 * FS, (white, fit.fitted)
    assert len(misses) <= 1, misses
