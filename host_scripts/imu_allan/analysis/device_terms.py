"""The device's own N and B beside the host's fit: the device reads each off one
point of its curve (N = adev(tau) * sqrt(tau) at the tau nearest 1 s, B =
min(adev) / 0.664; docs/protocol.md, T records), the fit separates the terms over
the whole curve.  Where the two differ, the fitted model at the device's tau says
why: at that tau the other terms add their share to the deviation the device read.

Each channel of the analysis document gets ``device_terms``:
``{"N": {"value", "tau_s", "pct", "fit", "model_at_tau", "other_share_pct",
"differs"}, "B": {...}}`` in the channel's rate units (``value`` the device's,
``fit`` the host's term, ``model_at_tau`` what the fitted terms predict the
device's reading to be, ``other_share_pct`` how much the terms other than this
one add there, in percent of the deviation)."""

from __future__ import annotations

import math
from typing import Any, Optional

import numpy as np

from ..device.records import DeviceReport, LRow
from ..noise.terms import B_READOFF


def add_device_terms(doc: dict[str, Any], report: Optional[DeviceReport]) -> None:
    """Put ``device_terms`` into each channel of ``doc`` whose report has a T record."""
    if report is None or not report.terms:
        return
    fs = float(report.header.fs_hz)
    rows = {(r.channel, r.level): r for r in report.rows}
    for ch, c in doc["channels"].items():
        t = report.terms.get(ch)
        if t is None:
            continue
        out = {}
        for name, term in (("N", t.N), ("B", t.B)):
            if term.level is None or term.value is None:
                continue
            tau = 2**term.level / fs
            row = rows.get((ch, term.level))
            p = row.pairs if row is not None else 0
            out[name] = _compare(c, name, _exact(term.value, row, tau, name) * c["scale_per_count"], tau, p)
        if out:
            c["device_terms"] = out


def _exact(printed: float, row: Optional[LRow], tau: float, name: str) -> float:
    """The device's term at full precision from its row's exact sum (as its human
    summary prints it), else as the T record printed it (3 digits)."""
    if row is None or row.pairs <= 0 or row.flags:
        return printed
    adev = math.sqrt(row.avar)
    return adev * math.sqrt(tau) if name == "N" else adev / B_READOFF


def _compare(c: dict[str, Any], name: str, value: float, tau: float, pairs: int) -> dict[str, Any]:
    pct = 100.0 / math.sqrt(2.0 * pairs) if pairs else None
    fit = c["terms"].get(name)
    total = _model_adev(c, tau)
    own = _own_adev(c, name, tau)
    if total is None or own is None:
        at_tau = share = None
    else:
        at_tau = total * math.sqrt(tau) if name == "N" else total / B_READOFF
        share = 100.0 * (total / own - 1.0) if own > 0 else None
    differs = None
    if fit is not None and value > 0:
        spread = max(2.0 * (pct or 0.0) / 100.0, (fit["high"] - fit["low"]) / (2.0 * fit["value"]))
        differs = abs(value / fit["value"] - 1.0) > spread
    return {
        "value": value,
        "tau_s": tau,
        "pct": pct,
        "fit": fit["value"] if fit else None,
        "model_at_tau": at_tau,
        "other_share_pct": share,
        "differs": differs,
    }


def _interp(c: dict[str, Any], line: list[Optional[float]], tau: float) -> Optional[float]:
    grid = np.array(c["fit"]["components"]["tau_s"], dtype=np.float64)
    v = np.array([np.nan if x is None else x for x in line], dtype=np.float64)
    ok = np.isfinite(v) & (v > 0)
    if not ok.any() or not grid[0] * (1 - 1e-9) <= tau <= grid[-1] * (1 + 1e-9):
        return None
    return float(np.exp(np.interp(math.log(tau), np.log(grid[ok]), np.log(v[ok]))))


def _model_adev(c: dict[str, Any], tau: float) -> Optional[float]:
    comp = (c.get("fit") or {}).get("components")
    return _interp(c, comp["total_adev"], tau) if comp and comp.get("total_adev") else None


def _own_adev(c: dict[str, Any], name: str, tau: float) -> Optional[float]:
    comp = (c.get("fit") or {}).get("components")
    if not comp or name not in (comp.get("adev") or {}):
        return None
    return _interp(c, comp["adev"][name], tau)
