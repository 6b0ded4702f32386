"""Synthetic thesis rows: 10-bit ADC codes from the thesis IMU noise model.

Per channel c and sample i (dt = 1/fs), in ADC counts:

    x_i = offset + white_i + bias_i + walk_i + flicker_i + drift * i * dt
    white_i  = white * N(0,1)                      (angle/velocity random walk)
    bias_i   = a * bias_{i-1} + gm_sigma * sqrt(1 - a^2) * N(0,1),
               a = exp(-dt / gm_tau)               (Gauss-Markov bias instability)
    walk_i   = walk_{i-1} + rrw * N(0,1)           (rate random walk)
    flicker_i = sum of Gauss-Markov processes      (1/f bias instability, IEEE 952 B)
    code_i   = clip(round(x_i), 0, 1023)           (or reflected: kind "walk")

Units: offset counts; white counts per sample (its Allan deviation at tau =
1/fs, before quantization; N = white / sqrt(fs) counts*sqrt(s)); gm_sigma
counts (stationary standard deviation; the bias starts stationary); gm_tau
seconds; rrw counts per sample (standard deviation of each step;
K = rrw * sqrt(fs) counts/sqrt(s)); drift counts per second; flicker
counts: the IEEE 952 bias instability coefficient B, whose Allan deviation
floor is 0.664 B. The processes are those of the one simulator, noise.py.

Every (channel, noise source) draws from its own stream spawned from the seed,
so a file depends only on the parameters, never on how it was cut in chunks.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from typing import Iterator, Optional

import numpy as np

from ..channels import CODE_MAX, COLUMNS
from ..errors import InputError
from .streams import NoiseParams, NoiseProcess
from .words import HELP, KINDS, PARAMS, PROFILES, UNITS  # noqa: F401  (their home: words.py)

CHUNK = 1 << 17

# The thesis board at rest (order ax ay az gx gy gz temp), of the order the
# thesis measured: accelerometer white noise ~2 counts, gyros ~0.85 counts.
THESIS = {
    "offset": (498, 494, 791, 520, 497, 498, 63),
    "white": (2.0, 2.5, 1.7, 0.85, 0.6, 0.5, 0.3),
    "gm_sigma": (0.2, 0.3, 0.05, 0.17, 0.06, 0.05, 0.5),
    "gm_tau": (10.0, 10.0, 10.0, 10.0, 10.0, 10.0, 600.0),
    "rrw": (0.0008, 0.0016, 0.0002, 0.0, 0.0, 0.0, 0.0),
    "drift": (0.0,) * 7,
    "flicker": (0.0,) * 7,
}
SQUARE_HALF_PERIOD = (1, 2, 4, 8, 16, 32)
"""kind "square": samples per half period of ax..gz (0 and 1023 alternate); temp is constant."""


@dataclass
class GenParams:
    n: int = 100_000
    fs_hz: float = 100.0
    seed: int = 1
    kind: str = "noise"
    profile: str = "thesis"
    boundary: str = "clip"
    channels: tuple[str, ...] = COLUMNS
    offset: dict[str, float] = field(default_factory=dict)
    white: dict[str, float] = field(default_factory=dict)
    gm_sigma: dict[str, float] = field(default_factory=dict)
    gm_tau: dict[str, float] = field(default_factory=dict)
    rrw: dict[str, float] = field(default_factory=dict)
    drift: dict[str, float] = field(default_factory=dict)
    flicker: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> str:
        d = dataclasses.asdict(self)
        d["channels"] = list(self.channels)
        d["units"] = UNITS
        if self.kind == "square":
            d["square_half_period"] = dict(zip(COLUMNS, SQUARE_HALF_PERIOD))
        return json.dumps(d, indent=1) + "\n"

    def command(self) -> str:
        """The ``imu-allan gen`` arguments that reproduce this file."""
        parts = [
            f"-n {self.n}",
            f"--fs {self.fs_hz!r}",
            f"--seed {self.seed}",
            f"--kind {self.kind}",
            f"--profile {self.profile}",
        ]
        for p in PARAMS:
            values = getattr(self, p)
            if p == "flicker" and not any(values.get(c, 0.0) for c in self.channels):
                continue  # a parameter added later: files without it keep their first line
            spec = ",".join(f"{c}={values[c]!r}" for c in self.channels)
            parts.append(f"--{p.replace('_', '-')} {spec}")
        return "imu-allan gen " + " ".join(parts)


def make_params(
    n: int = 100_000,
    fs_hz: float = 100.0,
    seed: int = 1,
    kind: str = "noise",
    profile: str = "thesis",
    **overrides: Optional[str | float | dict[str, float]],
) -> GenParams:
    """Defaults of ``profile`` adjusted for ``kind``, then ``overrides``.

    An override is a number (every channel), a dict, or a spec string
    ``"2.0"`` / ``"gx=0.9,gy=0.6"`` (channels not named keep their default).
    """
    if kind not in KINDS:
        raise InputError(f"unknown kind {kind!r} (one of {', '.join(KINDS)})")
    if profile not in PROFILES:
        raise InputError(f"unknown profile {profile!r} (one of {', '.join(PROFILES)})")
    if n < 0:
        raise InputError("-n must be at least 0")
    if not (fs_hz > 0 and math.isfinite(fs_hz)):
        raise InputError("--fs must be a positive number of Hz")
    base = {p: dict(zip(COLUMNS, map(float, THESIS[p]))) for p in PARAMS}
    sensors = COLUMNS[:6]
    boundary = "clip"
    if kind == "walk":
        boundary = "reflect"
        for c in sensors:
            base["white"][c], base["gm_sigma"][c], base["rrw"][c] = 0.0, 0.0, 2.0
    elif kind == "drift":
        for c, slope in zip(sensors, (0.05, -0.05, 0.03, 0.02, -0.02, 0.01)):
            base["drift"][c] = slope
    elif kind == "clip":
        for c in sensors:
            base["offset"][c], base["white"][c] = 512.0, 400.0
            base["gm_sigma"][c] = base["rrw"][c] = 0.0
    for p, spec in overrides.items():
        if p not in PARAMS:
            raise TypeError(f"unknown parameter {p}")
        if spec is None:
            continue
        base[p].update(
            parse_spec(spec, p)
            if isinstance(spec, str)
            else spec
            if isinstance(spec, dict)
            else dict.fromkeys(COLUMNS, float(spec))
        )
    for p in PARAMS:
        for c, v in base[p].items():
            if not math.isfinite(v) or (p != "drift" and p != "offset" and v < 0) or (p == "gm_tau" and v <= 0):
                raise InputError(f"--{p.replace('_', '-')} {c}={v}: out of range")
    return GenParams(n=n, fs_hz=float(fs_hz), seed=seed, kind=kind, profile=profile, boundary=boundary, **base)


def parse_spec(spec: str, what: str = "value") -> dict[str, float]:
    """``"2.0"`` -> every channel 2.0; ``"gx=0.9,gy=0.6"`` -> those channels."""
    out: dict[str, float] = {}
    try:
        if "=" not in spec:
            return dict.fromkeys(COLUMNS, float(spec))
        for item in spec.split(","):
            ch, _, val = item.partition("=")
            ch = ch.strip()
            if ch not in COLUMNS:
                raise InputError(f"--{what.replace('_', '-')}: unknown channel {ch!r} (channels: {' '.join(COLUMNS)})")
            out[ch] = float(val)
    except ValueError:
        raise InputError(
            f"--{what.replace('_', '-')} {spec!r}: expected a number or CH=NUMBER[,CH=NUMBER...]"
        ) from None
    return out


def generate(p: GenParams, chunk: int = CHUNK) -> Iterator[np.ndarray]:
    """Yield the stream as uint16 blocks of shape (7, rows)."""
    if p.kind == "square":
        yield from _square(p, chunk)
        return
    nch = len(p.channels)
    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(p.seed).spawn(3 * nch)]
    flicker_seeds = np.random.SeedSequence(p.seed).spawn(4 * nch)[3 * nch :]
    offset = np.array([p.offset[c] for c in p.channels])
    procs = [
        NoiseProcess(
            NoiseParams(
                white=p.white[ch],
                gm_sigma=p.gm_sigma[ch],
                gm_tau=p.gm_tau[ch],
                rrw=p.rrw[ch],
                flicker=p.flicker[ch],
                ramp=p.drift[ch],
            ),
            p.fs_hz,
            p.n,
            white_rng=streams[c],
            gm_rng=streams[nch + c],
            rrw_rng=streams[2 * nch + c],
            flicker_seed=flicker_seeds[c],
        )
        for c, ch in enumerate(p.channels)
    ]
    done = 0
    while done < p.n:
        c_len = min(chunk, p.n - done)
        x = np.repeat(offset[:, None], c_len, axis=1)
        for c, proc in enumerate(procs):  # over channels; each one vectorized over its samples
            proc.add_to(x[c], done)
        if p.boundary == "reflect":
            x = np.mod(x, 2 * CODE_MAX)
            x = np.where(x > CODE_MAX, 2 * CODE_MAX - x, x)
        yield np.clip(np.rint(x), 0, CODE_MAX).astype(np.uint16)
        done += c_len


def _square(p: GenParams, chunk: int) -> Iterator[np.ndarray]:
    done = 0
    while done < p.n:
        c_len = min(chunk, p.n - done)
        i = np.arange(done, done + c_len)
        out = np.empty((len(p.channels), c_len), dtype=np.uint16)
        for c, h in enumerate(SQUARE_HALF_PERIOD):
            out[c] = CODE_MAX * ((i // h) & 1)
        out[6:] = np.clip(np.rint([p.offset[c] for c in p.channels[6:]]), 0, CODE_MAX)[:, None]
        yield out
        done += c_len
