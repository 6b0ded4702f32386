"""Sensor profiles: from input values (ADC codes or numbers in a CSV) to rate units.

Each channel has a rate unit u: m/s^2 for the accelerometers (ax ay az),
deg/s for the gyroscopes (gx gy gz), or ``count`` when no scale is known.
``per_count`` is u per input unit; Allan variances scale by its square.

thesis   the board of the thesis, 10-bit ADC with Vref = 3.3 V:
             volts = code * Vref / 1024 - Vref / 2
             accelerometer MMA7260Q: g = volts / S, S = 800, 600, 300, 200 mV/g
                 at the 1.5, 2, 4, 6 g ranges; m/s^2 = g * 9.80665
             gyroscope LISY300AL: deg/s = volts / 3.3 mV/(deg/s)
         so one count is 3.3/1024/0.8 g = 4.028 mg = 0.03950 m/s^2 at 1.5 g
         and 3.3/1024/0.0033 = 0.9766 deg/s.
counts   every channel in ADC counts (no conversion).
generic  ``--scale CH=VALUE[UNIT]``: VALUE rate units per input unit. UNIT is
         optional: m/s^2 (default for a*), g, mg, ug; deg/s (default for g*),
         dps, rad/s, mrad/s, deg/h. Channels without a scale stay in counts.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Iterable, Optional

from ._firmware_facts import RANGES_G
from .channels import CHANNELS, CODE_MAX
from .errors import InputError

G0 = 9.80665
VREF = 3.3
ADC_STEPS = CODE_MAX + 1
ACC_SENSITIVITY_V_PER_G = {"1.5": 0.800, "2": 0.600, "4": 0.300, "6": 0.200}
GYRO_SENSITIVITY_V_PER_DPS = 0.0033
PROFILES = ("thesis", "counts")
RANGES = RANGES_G
"""The accelerometer ranges the device offers (g), in its order; each has a sensitivity above."""

KIND = {"ax": "acc", "ay": "acc", "az": "acc", "gx": "gyro", "gy": "gyro", "gz": "gyro"}
RATE_UNIT = {"acc": "m/s^2", "gyro": "deg/s"}
UNIT_FACTORS = {
    "acc": {"m/s^2": 1.0, "m/s2": 1.0, "m/s/s": 1.0, "g": G0, "mg": G0 * 1e-3, "ug": G0 * 1e-6},
    "gyro": {
        "deg/s": 1.0,
        "dps": 1.0,
        "rad/s": 180.0 / math.pi,
        "mrad/s": 0.18 / math.pi,
        "deg/h": 1.0 / 3600.0,
        "mdps": 1e-3,
    },
}


@dataclass(frozen=True)
class ChannelScale:
    channel: str
    unit: str  # "m/s^2", "deg/s" or "count"
    per_count: float  # unit per input unit
    zero: float = 0.0  # input value of zero rate (thesis: Vref/2, i.e. code 512)
    source: str = ""

    @property
    def kind(self) -> str:
        return "counts" if self.unit == "count" else KIND[self.channel]


@dataclass
class Profile:
    name: str
    channels: dict[str, ChannelScale]
    notes: list[str] = field(default_factory=list)

    def scale(self, ch: str) -> ChannelScale:
        return self.channels[ch]


def thesis_profile(range_g: str = "1.5") -> Profile:
    rg = normalize_range(range_g)
    volt = VREF / ADC_STEPS
    acc = volt / ACC_SENSITIVITY_V_PER_G[rg] * G0
    gyro = volt / GYRO_SENSITIVITY_V_PER_DPS
    sens = ACC_SENSITIVITY_V_PER_G[rg] * 1000
    chans = {}
    for ch in CHANNELS:
        if KIND[ch] == "acc":
            chans[ch] = ChannelScale(
                ch, "m/s^2", acc, ADC_STEPS / 2, f"MMA7260Q {sens:g} mV/g at {rg} g, Vref {VREF} V, 10-bit ADC"
            )
        else:
            chans[ch] = ChannelScale(
                ch,
                "deg/s",
                gyro,
                ADC_STEPS / 2,
                f"LISY300AL {GYRO_SENSITIVITY_V_PER_DPS * 1000:g} mV/(deg/s), Vref {VREF} V, 10-bit ADC",
            )
    return Profile(
        "thesis",
        chans,
        [
            f"thesis board: accelerometer range {rg} g, one count = {acc:.6g} m/s^2 "
            f"({acc / G0 * 1000:.4g} mg), gyroscope one count = {gyro:.6g} deg/s"
        ],
    )


def counts_profile() -> Profile:
    return Profile(
        "counts",
        {ch: ChannelScale(ch, "count", 1.0, 0.0, "ADC counts") for ch in CHANNELS},
        ["all channels in ADC counts"],
    )


def normalize_range(text: Optional[str]) -> str:
    if text is None:
        return "1.5"
    t = str(text).strip().lower().rstrip("g")
    try:
        v = float(t)
    except ValueError:
        raise InputError(f"accelerometer range {text!r}: one of {', '.join(RANGES)} (g)") from None
    for r in RANGES:
        if float(r) == v:
            return r
    raise InputError(f"accelerometer range {text!r}: one of {', '.join(RANGES)} (g)")


_SCALE = re.compile(r"^\s*([a-z]{2})\s*=\s*([-+0-9.eE]+)\s*([a-zA-Z/^0-9]*)\s*$")


SCALE_LIMITS = (1e-30, 1e30)
"""Scales --scale takes (rate units per count): beyond any sensor, and such that a
deviation's square and its variance's stay normal float64 numbers."""


def parse_scales(specs: list[str]) -> dict[str, tuple[float, str]]:
    """``["gx=0.05", "ax=0.0039g,ay=0.0039g"]`` -> {channel: (value, unit)}."""
    out: dict[str, tuple[float, str]] = {}
    for spec in specs:
        if not spec.replace(",", "").strip():
            raise InputError(f"--scale {spec!r}: names no channel; expected CH=VALUE[UNIT], e.g. gx=0.05")
        for item in spec.split(","):
            if not item.strip():
                continue
            m = _SCALE.match(item)
            if not m:
                raise InputError(
                    f"--scale {item!r}: expected CH=VALUE[UNIT], e.g. gx=0.05 or gx=0.001rad/s or ax=0.0039g"
                )
            ch, val, unit = m.group(1), m.group(2), m.group(3)
            if ch not in CHANNELS:
                raise InputError(f"--scale {item!r}: unknown channel {ch!r} (channels: {' '.join(CHANNELS)})")
            try:
                v = float(val)
            except ValueError:
                raise InputError(f"--scale {item!r}: {val!r} is not a number") from None
            if not (v > 0 and math.isfinite(v)):
                raise InputError(f"--scale {item!r}: the scale must be a positive number")
            if not SCALE_LIMITS[0] <= v <= SCALE_LIMITS[1]:
                raise InputError(f"--scale {item!r}: outside {SCALE_LIMITS[0]:g} .. {SCALE_LIMITS[1]:g}")
            if ch in out:
                raise InputError(f"--scale {item!r}: {ch} has a scale already ({out[ch][0]:g} {out[ch][1]})")
            kind = KIND[ch]
            unit = unit or RATE_UNIT[kind]
            if unit.lower() not in {u.lower() for u in UNIT_FACTORS[kind]}:
                raise InputError(
                    f"--scale {item!r}: unit {unit!r} is not a {kind} rate unit ({', '.join(UNIT_FACTORS[kind])})"
                )
            out[ch] = (v, unit)
    return out


def unit_factor(ch: str, unit: str) -> float:
    table = UNIT_FACTORS[KIND[ch]]
    for u, f in table.items():
        if u.lower() == unit.lower():
            return f
    raise InputError(f"{ch}: unit {unit!r} is not a {KIND[ch]} rate unit ({', '.join(table)})")


def build_profile(
    name: Optional[str],
    scales: dict[str, tuple[float, str]],
    range_g: Optional[str] = None,
    channels: Optional[Iterable[str]] = None,
) -> Profile:
    """``--profile`` (default thesis when no scale is given) with ``--scale`` on top.

    ``channels``: the input's channels, when known, so that the note on channels left
    in ADC counts names only channels the input has (a three-gyro file with its units
    in the header has none left in counts)."""
    if name is None:
        base = counts_profile() if scales else thesis_profile(range_g or "1.5")
        if scales:
            base.name = "generic"
            present = set(KIND if channels is None else channels)
            in_counts = [ch for ch in KIND if ch in present and ch not in scales]
            base.notes = (
                [f"generic profile: {', '.join(in_counts)} without --scale stay in ADC counts"] if in_counts else []
            )
    elif name == "thesis":
        base = thesis_profile(range_g or "1.5")
    elif name == "counts":
        base = counts_profile()
    else:
        raise InputError(f"unknown profile {name!r} (one of {', '.join(PROFILES)}, or --scale)")
    for ch, (v, unit) in scales.items():
        base.channels[ch] = ChannelScale(
            ch, RATE_UNIT[KIND[ch]], v * unit_factor(ch, unit), 0.0, f"--scale {ch}={v:g}{unit}"
        )
    return base


def resolve_range(given: Optional[str], header_range: Optional[str]) -> Optional[str]:
    """The accelerometer range: the device header's when it says one (a
    ``--range`` that contradicts it is an error), else the one given."""
    if header_range is None:
        return given
    hr = normalize_range(header_range)
    if given is not None and normalize_range(given) != hr:
        raise InputError(f"--range {given} contradicts the device header (range={hr} g)")
    return hr


def scales_for_input(
    name: str, channels: list[str], integer: bool, units: dict[str, str], scales: dict[str, tuple[float, str]]
) -> dict[str, tuple[float, str]]:
    """The scales of an input that is not plain ADC codes (a CSV): the units
    its header names, unless ``--scale`` says otherwise; values that are not
    10-bit codes need a unit for every channel."""
    given = dict(scales)
    for ch, unit in units.items():
        if ch not in given:
            try:
                given.update(parse_scales([f"{ch}=1{unit}"]))
            except InputError:
                raise InputError(
                    f"'{name}': column {ch} has unit [{unit}], not a rate unit "
                    "this tool knows (m/s^2, g, mg, deg/s, rad/s ...)"
                ) from None
    missing = [c for c in channels if c not in given]
    if missing and not integer:
        raise InputError(
            f"'{name}': the values are not 10-bit ADC codes, so the thesis scale "
            f"does not apply: give the unit of {', '.join(missing)} with --scale "
            f"(e.g. --scale {missing[0]}=1{'rad/s' if missing[0][0] == 'g' else 'm/s^2'}), "
            "or --profile counts"
        )
    return given


# ---- units the literature uses ---------------------------------------------------------

TERM_UNIT = {"Q": "{u}*s", "N": "{u}*sqrt(s)", "B": "{u}", "K": "{u}/sqrt(s)", "R": "{u}/s"}
"""JSON units of the terms, u the channel's rate unit, time in seconds."""

# (unit label, factor from the JSON unit) per kind and term, for people
LITERATURE = {
    "gyro": {
        "Q": ("deg", 1.0),
        "N": ("deg/sqrt(h)", 60.0),
        "B": ("deg/h", 3600.0),
        "K": ("deg/h/sqrt(h)", 216000.0),
        "R": ("deg/h^2", 3600.0**2),
    },
    "acc": {
        "Q": ("m/s", 1.0),
        "N": ("m/s/sqrt(h)", 60.0),
        "B": ("ug", 1e6 / G0),
        "K": ("m/s/h/sqrt(h)", 216000.0),
        "R": ("m/s/h^2", 3600.0**2),
    },
    "counts": {
        "Q": ("count*s", 1.0),
        "N": ("count*sqrt(s)", 1.0),
        "B": ("count", 1.0),
        "K": ("count/sqrt(s)", 1.0),
        "R": ("count/s", 1.0),
    },
}


def term_unit(scale: ChannelScale, term: str) -> str:
    return TERM_UNIT[term].format(u=scale.unit)


def literature(scale: ChannelScale, term: str) -> tuple[str, float]:
    return LITERATURE[scale.kind][term]


def to_si_rad(scale: ChannelScale) -> float:
    """Factor to the SI rate unit: deg/s -> rad/s; m/s^2 and counts unchanged."""
    return math.pi / 180.0 if scale.unit == "deg/s" else 1.0
