"""A continuous-time model of the thesis board's sensors, sampled where the ADC samples.

Each sensor channel c is a continuous process, in ADC counts:

    x_c(t) = offset + lp(t) + bias(t) + walk(t) + tempco * dT(t) + tempco2 * dT(t)^2

    lp     white rate noise of two-sided density N^2 (counts^2/Hz; unfiltered
           Allan deviation N / sqrt(tau), IEEE 952 N in counts*sqrt(s)) through
           the sensor's first-order analog low-pass at ``bandwidth_hz`` f_c.
           That is an Ornstein-Uhlenbeck process of time constant
           T = 1 / (2 pi f_c) and variance sigma^2 = pi f_c N^2.
    bias   bias instability: a Gauss-Markov process (``gm_sigma`` counts,
           ``gm_tau`` s) and/or flicker of IEEE 952 coefficient ``B`` counts
           (the catalogue's bank of Gauss-Markov processes, correlation times
           1/f_s ... 4x the record spaced by 8: their PSDs sum to the flicker
           PSD B^2 / (2 pi f), two-sided).
    walk   rate random walk, K counts/sqrt(s): increments N(0, K^2 dt).
    dT     temperature minus ``temperature.start_c``.

Each column is sampled at a uniform step (its own delay after every tick), so
each process is the noise catalogue's own (processes.py; ``channel_model``): an
OU process sampled every h is exactly an AR(1) of pole exp(-h / T) (Gillespie
1996, Phys. Rev. E 54, 2084), the same process ``imu-allan gen`` simulates and
the noise fit fits. The model is therefore simulated *at the sampling instants
themselves*, never on a finer grid, and noise above half the sample rate
aliases exactly as it does on the bench: white noise of density S0 through
the low-pass, sampled instantaneously at f_s, has a sample PSD at low
frequencies of (Poisson summation over the aliases)

    S0 (pi f_c / f_s) coth(pi f_c / f_s)               (``aliased_n``)

so the N read from the samples falls with f_s until f_s >> f_c, while the
samples' standard deviation sqrt(pi f_c) N does not depend on f_s.

Sampling instants (firmware/adc.c, docs/firmware.md): Timer1 ticks at
i / f_s; its ISR starts the scan of the 7 columns ax ay az gx gy gz temp,
which the ADC then converts back to back (free running): a normal conversion
takes 13 ADC clocks and samples the input 1.5 clocks after it starts; the
tick's start waits about one clock for the ADC clock's edge, so column k is sampled
at i / f_s + (``start_clocks`` + 1.5 + ``conversion_clocks`` k) / f_adc,
f_adc = 10 MHz / 64 = 156.25 kHz. With ``average`` M > 1 the device would
scan M times per sample period (at M f_s) and average the M codes: an
anti-alias filter of the samples (see docs/thesis-questions.md).

The codes are round(x) clipped to 0 .. 1023. The temperature column reads
the temperature profile through a sensor of ``c_per_count`` degC per count
above ``offset_c`` (default an LM35-like 10 mV/degC on the 3.3 V, 10-bit ADC:
0.3223 degC per count; the thesis does not name its sensor), plus white
noise of ``noise`` counts.

Model file (JSON), every key optional (missing ones keep the defaults)::

    {"adc": {"clock_hz": 156250, "conversion_clocks": 13, "start_clocks": 1},
     "temperature": {"start_c": 20.3, "ramp_c_per_s": 0, "sine_c": 0, "period_s": 3600,
                     "c_per_count": 0.3223, "offset_c": 0, "noise": 0.3},
     "channels": {"gx": {"offset": 520, "N": 0.048, "bandwidth_hz": 88, "B": 0.056,
                         "K": 0, "gm_sigma": 0, "gm_tau": 10, "tempco": 0.1, "tempco2": 0}}}
"""

from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass
from typing import Any, Iterator, Optional

import numpy as np

from ..channels import CODE_MAX, COLUMNS
from ..errors import InputError
from .flicker import Flicker
from .processes import AR1, RW, Model

SENSORS = COLUMNS[:6]
F_ADC = 10_000_000 / 64
CHANNEL_KEYS = ("offset", "N", "bandwidth_hz", "B", "K", "gm_sigma", "gm_tau", "tempco", "tempco2")
UNITS = {
    "offset": "counts",
    "N": "counts*sqrt(s) (sqrt of the two-sided white density, before the low-pass)",
    "bandwidth_hz": "Hz (first-order low-pass corner)",
    "B": "counts (IEEE 952 bias instability)",
    "K": "counts/sqrt(s) (rate random walk)",
    "gm_sigma": "counts (Gauss-Markov bias sigma)",
    "gm_tau": "s (Gauss-Markov correlation time)",
    "tempco": "counts/degC",
    "tempco2": "counts/degC^2",
}


def _thesis_channel(
    sigma_counts: float, bandwidth: float, B: float, K: float, offset: float, tempco: float
) -> dict[str, float]:
    # The thesis' sigma_sensor at 100 Hz includes the ADC's 1/12 count^2 of rounding;
    # the sampled low-passed noise has variance pi f_c N^2 at any rate.
    N = math.sqrt(max(sigma_counts**2 - 1.0 / 12.0, 0.0) / (math.pi * bandwidth))
    return {
        "offset": offset,
        "N": N,
        "bandwidth_hz": bandwidth,
        "B": B,
        "K": K,
        "gm_sigma": 0.0,
        "gm_tau": 10.0,
        "tempco": tempco,
        "tempco2": 0.0,
    }


# Thesis section 7 at 100 Hz, in counts of the board at 1.5 g (4.028 mg and
# 0.9766 deg/s per count, see thesis.py): sigma_sensor, B and K per axis.
# Bandwidths: MMA7260Q 350 Hz X/Y, 150 Hz Z; LISY300AL 88 Hz. Tempcos are
# illustrative (of the order of the datasheets' zero-level drifts), not measured.
DEFAULT_MODEL: dict[str, Any] = {
    "adc": {"clock_hz": F_ADC, "conversion_clocks": 13.0, "start_clocks": 1.0},
    "temperature": {
        "start_c": 20.3,
        "ramp_c_per_s": 0.0,
        "sine_c": 0.0,
        "period_s": 3600.0,
        "c_per_count": 3.3 / 1024 / 0.010,
        "offset_c": 0.0,
        "noise": 0.3,
    },
    "channels": {
        "ax": _thesis_channel(1.879, 350.0, 0.0837, 0.0104, 498.0, 0.2),
        "ay": _thesis_channel(2.341, 350.0, 0.1020, 0.0218, 494.0, 0.2),
        "az": _thesis_channel(1.631, 150.0, 0.0323, 0.00186, 791.0, 0.2),
        "gx": _thesis_channel(0.847, 88.0, 0.0560, 0.0, 520.0, 0.1),
        "gy": _thesis_channel(0.578, 88.0, 0.0524, 0.0, 497.0, 0.1),
        "gz": _thesis_channel(0.489, 88.0, 0.0508, 0.0, 498.0, 0.1),
    },
}


@dataclass
class SensorModel:
    doc: dict[str, Any]

    def channel(self, ch: str) -> dict[str, float]:
        return self.doc["channels"][ch]

    def offsets_s(self) -> np.ndarray:
        """Sampling delay of each column after the Timer1 tick, s."""
        a = self.doc["adc"]
        k = np.arange(len(COLUMNS))
        return (a["start_clocks"] + 1.5 + a["conversion_clocks"] * k) / a["clock_hz"]

    def temperature(self, t: np.ndarray) -> np.ndarray:
        p = self.doc["temperature"]
        out = p["start_c"] + p["ramp_c_per_s"] * t
        if p["sine_c"]:
            out = out + p["sine_c"] * np.sin(2 * math.pi * t / p["period_s"])
        return out

    def to_json(self) -> str:
        return json.dumps({**self.doc, "units": UNITS}, indent=1) + "\n"


def default_model() -> SensorModel:
    return SensorModel(copy.deepcopy(DEFAULT_MODEL))


def load_model(path: Optional[str]) -> SensorModel:
    """The default model updated by the JSON file ``path`` (one line per error)."""
    m = default_model()
    if path is None:
        return m
    try:
        with open(path) as f:
            doc = json.load(f)
    except OSError as exc:
        raise InputError(f"cannot read '{path}': {exc.strerror or exc}") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"'{path}' line {exc.lineno}: not JSON ({exc.msg})") from None
    if not isinstance(doc, dict):
        raise InputError(f"'{path}': a model file is a JSON object")
    for section in ("adc", "temperature"):
        for k, v in (doc.get(section) or {}).items():
            if k not in m.doc[section]:
                raise InputError(f"'{path}': unknown key {section}.{k} (known: {', '.join(m.doc[section])})")
            m.doc[section][k] = _number(v, f"{section}.{k}", path)
    for ch, params in (doc.get("channels") or {}).items():
        if ch not in SENSORS:
            raise InputError(f"'{path}': unknown channel {ch!r} (channels: {' '.join(SENSORS)})")
        for k, v in params.items():
            if k not in CHANNEL_KEYS:
                raise InputError(f"'{path}': unknown key channels.{ch}.{k} (known: {', '.join(CHANNEL_KEYS)})")
            m.doc["channels"][ch][k] = _number(v, f"channels.{ch}.{k}", path)
    for ch in SENSORS:
        c = m.doc["channels"][ch]
        for k in ("N", "B", "K", "gm_sigma"):
            if c[k] < 0:
                raise InputError(f"'{path}': channels.{ch}.{k} must not be negative")
        for k in ("bandwidth_hz", "gm_tau"):
            if c[k] <= 0:
                raise InputError(f"'{path}': channels.{ch}.{k} must be positive")
    t = m.doc["temperature"]
    if t["c_per_count"] <= 0 or t["period_s"] <= 0 or m.doc["adc"]["clock_hz"] <= 0:
        raise InputError(f"'{path}': temperature.c_per_count, period_s and adc.clock_hz must be positive")
    return m


def _number(v: Any, what: str, path: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"'{path}': {what} must be a finite number, not {v!r}")
    return float(v)


# ---- the laws -------------------------------------------------------------------------


def aliased_density(S0: float, fc: float, fs: float) -> float:
    """Low-frequency two-sided PSD of white noise (density S0) through a first-order
    low-pass at fc, sampled instantaneously at fs: S0 x coth(x), x = pi fc / fs."""
    x = math.pi * fc / fs
    return S0 * x / math.tanh(x)


def aliased_n(N: float, fc: float, fs: float, quantization: bool = True, average: int = 1) -> float:
    """The N (counts*sqrt(s)) read from the samples at long tau: the aliasing law,
    plus the ADC's rounding (1/12 count^2 of white noise per sample) if asked.

    With ``average`` M (the mean of M scans spread evenly over each sample period, a
    boxcar whose zeros sit on the multiples of fs), only the aliases at multiples of
    M fs remain: the law at M fs; the rounding is 1/(12 M) count^2 for the M codes
    plus 1/12 for rounding their mean."""
    q = (1.0 + (1.0 / average if average > 1 else 0.0)) / (12.0 * fs) if average > 1 else 1.0 / (12.0 * fs)
    v = aliased_density(N * N, fc, fs * average) + (q if quantization else 0.0)
    return math.sqrt(v)


def lowpass_sigma(N: float, fc: float) -> float:
    """Standard deviation of the low-passed white noise (any sample rate), counts."""
    return math.sqrt(math.pi * fc) * N


# ---- each channel, a sum of catalogue processes ---------------------------------------------


def channel_model(p: dict[str, float]) -> Model:
    """One channel's noise (counts) as a sum of the catalogue's processes (processes.py),
    for samples taken at any uniform step: an OU process of time constant T sampled every
    h is exactly the AR(1) of pole exp(-h / T) (Gillespie 1996), so the low-passed white
    noise is AR1(sqrt(pi f_c) N, 1 / (2 pi f_c)), the bias AR1(gm_sigma, gm_tau), the walk
    RW(K) and the flicker the catalogue's bank Flicker(B)."""
    parts: list = []
    if p["N"]:
        parts.append(AR1(lowpass_sigma(p["N"], p["bandwidth_hz"]), 1.0 / (2 * math.pi * p["bandwidth_hz"])))
    if p["gm_sigma"]:
        parts.append(AR1(p["gm_sigma"], p["gm_tau"]))
    if p["K"]:
        parts.append(RW(p["K"]))
    if p["B"]:
        parts.append(Flicker(p["B"]))
    return Model(parts)


# ---- the board --------------------------------------------------------------------------


def sample_instants(model: SensorModel, fs: float, start: int, count: int) -> np.ndarray:
    """(7, count) sampling instants of ticks start .. start+count-1, s."""
    ticks = np.arange(start, start + count, dtype=np.float64) / fs
    return ticks[None, :] + model.offsets_s()[:, None]


class Board:
    """The 7 ADC columns of the board at the device's instants, block by block
    (``codes`` on consecutive blocks, or ``blocks``)."""

    def __init__(self, model: SensorModel, fs: float, n: int, seed: int = 1, average: int = 1) -> None:
        if average < 1:
            raise InputError("average must be at least 1")
        self.model, self.fs, self.n, self.average = model, float(fs), n, average
        ss = np.random.SeedSequence(seed).spawn(len(COLUMNS))
        # each column is sampled at a uniform step (its own delay after each tick): the
        # catalogue's processes at M fs; the delays matter only to the temperature profile
        self.streams = [
            channel_model(model.channel(ch)).simulator(self.fs * average, n * average, ss[c])
            for c, ch in enumerate(SENSORS)
        ]
        self.temp_rng = np.random.default_rng(ss[6])
        self.done = 0
        self._next = 0

    def blocks(self, chunk: int = 1 << 16) -> Iterator[np.ndarray]:
        """uint16 codes, blocks of shape (7, rows)."""
        while self.done < self.n:
            L = min(chunk, self.n - self.done)
            yield self.codes(self.done, L)
            self.done += L

    def codes(self, start: int, count: int) -> np.ndarray:
        if start != self._next:
            raise ValueError(f"blocks must be consecutive: expected row {self._next}, got {start}")
        self._next = start + count
        M = self.average
        t = sample_instants(self.model, self.fs * M, start * M, count * M)
        out = np.empty((len(COLUMNS), count * M))
        t0 = self.model.doc["temperature"]["start_c"]
        for c, ch in enumerate(SENSORS):
            p = self.model.channel(ch)
            out[c] = p["offset"] + self.streams[c].take(count * M)
            if p["tempco"] or p["tempco2"]:
                dT = self.model.temperature(t[c]) - t0
                out[c] += p["tempco"] * dT + p["tempco2"] * dT * dT
        tp = self.model.doc["temperature"]
        out[6] = (self.model.temperature(t[6]) - tp["offset_c"]) / tp["c_per_count"] + tp[
            "noise"
        ] * self.temp_rng.standard_normal(t[6].size)
        codes = np.clip(np.rint(out), 0, CODE_MAX)
        if M > 1:  # the device's average of M scans (integer mean, rounded)
            codes = np.rint(codes.reshape(len(COLUMNS), count, M).mean(axis=2))
        return codes.astype(np.uint16)


def rows_header(fs: float, n: int, seed: int = 1, average: int = 1) -> bytes:
    """The comment lines that open a rows file of the board (``Board.blocks`` its rows)."""
    return (
        f"# imu-allan sensor model, fs {fs:g} Hz, {n} rows, seed {seed}"
        f"{f', average {average}' if average > 1 else ''}\n"
        f"# columns: {' '.join(COLUMNS)} (10-bit ADC codes)\n"
    ).encode()
