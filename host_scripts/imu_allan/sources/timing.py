"""Time stamps of a file: the sample rate they give and the gaps they show.

A CSV time column, a bag's header stamps and an array's time column are read
alike: the rate from the first rows (the statistics need it before the pass),
then every step checked while the samples stream past, and one note at the end
of the first whole pass saying what was found (gaps, steps backwards, a rate
that drifts from the first rows'), next to the numbers it could mislead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

from ..errors import InputError

FS_RANGE = (0.1, 100e3)
"""Sample rates a time column may give, Hz; outside, its unit was misread."""

GAP_STEPS = 1.5
"""A step over this many sample periods is a gap (samples missing)."""

FS_AGREE = 0.01
"""--fs and a time column agree within this fraction (clocks drift, stamps jitter)."""

BUNCHED = 0.05
"""Stamps are bunched when more than this fraction of the first steps are shorter
than half the median step: a regular series has none, but stamps taken when the
samples arrive (a bag's receive times, a driver's clock) come in pairs and bursts.
The median step is then no period; the span over the rows is (bunching moves
stamps, not the count of samples between them)."""

COARSE_MIN = 10
"""Long steps and steps not forward, each at least this many, before stamps are read as
rounded coarser than the sample period (TimeCheck._coarse): one gap beside one repeated
stamp is a gap and a repeat."""

UNIT_NAMES = {1e-9: "ns", 1e-6: "us", 1e-3: "ms", 1.0: "s"}


def time_unit(t: np.ndarray, step: float, origin: float = 0.0) -> float:
    """Seconds per unit of a time column named without a unit (``%time`` of
    ``rostopic echo -p`` is integer ns): epoch values tell by their size
    (~1.7e18 ns, 1.7e15 us, 1.7e12 ms, 1.7e9 s); times from 0 by the step,
    the first unit in s, ms, us, ns that gives 1 Hz .. 10 kHz."""
    t0 = abs(origin + float(t[0])) if t.size else abs(origin)
    for size, factor in ((1e17, 1e-9), (1e14, 1e-6), (1e11, 1e-3)):
        if t0 >= size:
            return factor
    if t0 < 1e8 and step > 0:
        for factor in (1.0, 1e-3, 1e-6, 1e-9):
            if 1.0 <= 1.0 / (step * factor) <= 1e4:
                return factor
    return 1.0


def rate_from_time(
    name: str, t: np.ndarray, factor: Optional[float], what: str = "the time column", origin: float = 0.0
) -> "TimeCheck":
    """The rate the first stamps ``t`` give (``factor``: seconds per unit, None to
    read it from the values; ``origin``: what ``t`` counts from, for that), as a
    TimeCheck ready to follow the whole pass."""
    steps = np.diff(t)
    steps = steps[np.isfinite(steps)]
    raw = float(np.median(steps)) if steps.size else math.nan
    if not (raw > 0 and math.isfinite(raw)):
        raise InputError(f"'{name}': {what} does not increase over its first rows: no sample rate from it")
    how = "named" if factor is not None else "read from the values"
    factor = time_unit(t, raw, origin) if factor is None else factor
    med = raw * factor
    fs = 1.0 / med
    span = float(t[-1] - t[0]) * factor
    short = float(np.mean(steps * factor < 0.5 * med))  # the share of steps under half the median
    bunched = span > 0 and short > BUNCHED
    if span > 0 and (bunched or np.all(np.abs(steps * factor - med) <= 0.01 * med)):
        fs = (t.size - 1) / span  # regular steps: the span, not one step, sets the rate
        # (epoch ns in float64 are quantized to 256 ns: one step is that coarse, the span is not)
    gap_s = GAP_STEPS / fs
    if bunched:  # a gap is a step longer than the bunching's own long steps
        gap_s = max(gap_s, GAP_STEPS * float(np.percentile(steps, 99)) * factor)
    if not FS_RANGE[0] <= fs <= FS_RANGE[1]:
        raise InputError(
            f"'{name}': {what} gives {fs:.6g} Hz (median step {med:.6g} s, unit "
            f"{how}), outside {FS_RANGE[0]:g} Hz .. {FS_RANGE[1]:g} Hz: give its unit in the "
            "header (e.g. 'time [ns]') or --fs"
        )
    jitter = float(np.max(np.abs(steps * factor - med)) / med)
    unit = UNIT_NAMES.get(factor, f"{factor:g} s")
    note = (
        f"sample rate {fs:.6g} Hz from {what} (in {unit}, {how}; median step {med:.6g} s"
        + (f", steps vary by up to {jitter * 100:.0f} %, more than 1 %" if jitter > 0.01 else "")
        + (
            f"; the stamps come bunched ({short * 100:.0f} % of the steps"
            " under half the median), so the rate is the rows over their span"
            if bunched
            else ""
        )
        + ")"
    )
    return TimeCheck(name, what, fs, factor, note, gap_s=gap_s)


@dataclass
class TimeCheck:
    """Follows the stamps of one pass: ``feed`` each block's stamps (in the
    column's unit), ``finish`` at the end; the first whole pass leaves its
    findings in ``found`` and a note (``summary``)."""

    name: str
    what: str
    fs: float
    factor: float
    note: str
    gap_s: float
    """A step longer than this (s) is a gap: GAP_STEPS sample periods, or the bunching's long steps'."""
    found: dict[str, Any] = field(default_factory=dict)
    _last: Optional[float] = None
    _first: Optional[float] = None
    _rows: int = 0
    _gaps: int = 0
    _missing: float = 0.0
    _longest: float = 0.0
    _longest_at: float = 0.0
    _back: int = 0
    _shortest_gap: float = math.inf

    def start(self) -> None:
        self._last = self._first = None
        self._rows = self._gaps = self._back = 0
        self._missing = self._longest = self._longest_at = 0.0
        self._shortest_gap = math.inf

    def feed(self, t: np.ndarray) -> None:
        if not t.size:
            return
        t = np.asarray(t, dtype=np.float64)
        if self._first is None:
            self._first = float(t[0])
        prev = t[0] if self._last is None else self._last
        steps = np.diff(t, prepend=prev) * self.factor  # seconds
        period = 1.0 / self.fs
        gap = steps > self.gap_s
        if gap.any():
            self._gaps += int(np.count_nonzero(gap))
            self._missing += float(np.sum(np.rint(steps[gap] / period) - 1.0))
            self._shortest_gap = min(self._shortest_gap, float(steps[gap].min()))
            k = int(np.argmax(steps))
            if steps[k] > self._longest:
                self._longest = float(steps[k])
                self._longest_at = (float(t[k]) - self._first) * self.factor
        self._back += int(np.count_nonzero(steps <= 0)) - (1 if self._last is None else 0)
        self._last = float(t[-1])
        self._rows += int(t.size)

    def finish(self, notes: list[str]) -> None:
        """End of a whole pass: the findings, and one note the first time."""
        if self.found or self._first is None or self._last is None:
            return
        span = (self._last - self._first) * self.factor
        self.found = {
            "rows": self._rows,
            "span_s": span,
            "gaps": self._gaps,
            "missing_samples": int(self._missing),
            "longest_gap_s": self._longest,
            "steps_not_forward": self._back,
        }
        said = []
        coarse = self._coarse(span)
        if coarse:  # stamps written coarser than the sample period, not samples missing
            self.found["missing_samples"], self._missing = 0, 0.0
            self.found["coarse_stamps"] = True
            said.append(
                f"{self._gaps} steps over {self.gap_s * self.fs:.3g} sample periods and {self._back} that do "
                f"not go forward, while the rows over the span give {(self._rows - 1) / span:.6g} Hz, the "
                "first rows' rate: the stamps are coarser than the sample period there (rounded), "
                "no samples are missing"
            )
        elif self._gaps:
            said.append(
                f"{self._gaps} gap{'s' if self._gaps > 1 else ''} (steps over "
                f"{self.gap_s * self.fs:.3g} sample periods; "
                f"about {int(self._missing)} samples missing; the longest {self._longest:.6g} s, "
                f"{self._longest_at:.6g} s in): the series has gaps, which the statistics take as continuous"
            )
        if self._back and not coarse:
            said.append(
                f"{self._back} step{'s' if self._back > 1 else ''} that do not go forward (repeated or out of order)"
            )
        whole = (self._rows - 1 + self._missing) / span if span > 0 else self.fs  # missing samples add periods
        if span > 0 and abs(whole - self.fs) > 1e-3 * self.fs:
            said.append(f"over the whole file the stamps give {whole:.6g} Hz, not the first rows' {self.fs:.6g} Hz")
        if said:
            notes.append(f"{self.what}: " + "; ".join(said))

    def _coarse(self, span: float) -> bool:
        """Stamps rounded coarser than the sample period (a writer's fixed decimals or
        significant digits): many long steps and many that do not go forward, and the rows
        over the span at the first rows' rate, to the stamps' own resolution."""
        if min(self._gaps, self._back) < COARSE_MIN or span <= 0:
            return False
        # the span's ends are each off by at most a quantum (the shortest long step): the rows
        # it holds at the first rows' rate are known to that, and must all be there
        return abs((self._rows - 1) - span * self.fs) <= 2.0 * self._shortest_gap * self.fs + 1.0
