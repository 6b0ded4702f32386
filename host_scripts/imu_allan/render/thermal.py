"""The text of ``imu-allan thermal``'s document (analysis/thermal.py): a row
per channel with its tempco and the noise terms before and after removing the
thermal bias, then the quadratic fits, the units and the notes."""

from __future__ import annotations

from typing import Any, Optional


def _iv(v: Optional[dict[str, Any]]) -> str:
    if not v:
        return "-"
    return f"{v['value']:.3g} [{v['low']:.3g}, {v['high']:.3g}]"


def text(doc: dict[str, Any]) -> str:
    t = doc["temperature"]
    lines = [
        f"{doc['file']}: {doc['n']} samples at {doc['fs_hz']:g} Hz ({doc['n'] / doc['fs_hz']:.0f} s); "
        f"temperature {t['min']:.4g} .. {t['max']:.4g} {t['unit']} (block means)",
        "",
    ]
    if not doc.get("fitted", True):
        return "\n".join(lines + doc["notes"]) + "\n"
    head = (
        "ch",
        "tempco [95 %]",
        "unit",
        "model",
        "N before",
        "N after",
        "B before",
        "B after",
        "K before",
        "K after",
        "R before",
        "R after",
        "FIT% raw",
        "FIT% +thermal",
    )
    rows = [head] + [_table_row(ch, c) for ch, c in doc["channels"].items()]
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    lines += ["  ".join(s.rjust(w) for s, w in zip(r, widths)) for r in rows]
    return _text_tail(doc, lines)


def _table_row(ch: str, c: dict[str, Any]) -> tuple[str, ...]:
    fp = c["fit_percent"]
    f = lambda v: "-" if v is None else f"{v:.1f}"  # noqa: E731
    return (
        ch,
        _iv(c["tempco"]),
        c["tempco"]["unit"],
        c["model"],
        _iv(c["terms_before"].get("N")),
        _iv(c["terms_after"].get("N")),
        _iv(c["terms_before"].get("B")),
        _iv(c["terms_after"].get("B")),
        _iv(c["terms_before"].get("K")),
        _iv(c["terms_after"].get("K")),
        _iv(c["terms_before"].get("R")),
        _iv(c["terms_after"].get("R")),
        f(fp["noise_model_on_raw"]),
        f(fp["noise_plus_thermal_on_raw"]),
    )


def _text_tail(doc: dict[str, Any], lines: list[str]) -> str:
    for ch, c in doc["channels"].items():
        if c["quadratic"]:
            q = c["quadratic"]
            lines.append(
                f"{ch}: quadratic supported (F-test p = {c['quadratic_test']['p_value']:.2g}): "
                f"c1 {_iv(q['c1'])}, c2 {_iv(q['c2'])} {q['unit_c2']} around {q['t_ref']:.4g}"
            )
    u = next(iter(doc["channels"].values()))["term_units"]
    lines.append(
        f"units: N {u['N']}, B {u['B']}, K {u['K']}, R {u['R']}; FIT%: the thesis' formula on "
        "log10 ADEV of the raw series, for the noise model of its own terms (raw) and for the "
        "noise model of the corrected series plus the thermal term (+thermal)"
    )
    for ch, c in doc["channels"].items():
        bt = c.get("terms_by_temperature")
        if not bt:
            continue
        parts = []
        for q in ("N", "B"):
            vals = ", ".join(f"{v['value']:.3g}" if v else "-" for v in bt[q])
            sl = bt[f"{q}_slope"]
            parts.append(
                f"{q} {vals}"
                + (
                    f" ({sl['verdict']}: slope {sl['value']:.2g} [{sl['low']:.2g}, {sl['high']:.2g}] per {bt['unit']})"
                    if sl
                    else ""
                )
            )
        lines.append(f"{ch} at {', '.join(f'{t:.4g}' for t in bt['temperature'])} {bt['unit']}: " + "; ".join(parts))
    lines += [f"note: {n}" for n in doc["notes"]]
    return "\n".join(lines) + "\n"
