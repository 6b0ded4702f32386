"""The firmware's scale table (firmware/units.h, units.c) and the host's
(profiles.py) hold the same facts of the thesis board: one home each, checked
here.  The factors the firmware derives from them are recomputed from
profiles.py and compared with the C expressions' inputs."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from imu_allan import profiles

UNITS_H = Path(__file__).resolve().parents[2] / "firmware" / "units.h"


def _defines() -> dict[str, float]:
    out = {}
    for m in re.finditer(r"^#define (UNITS_\w+) ([0-9.]+)", UNITS_H.read_text(), re.M):
        out[m.group(1)] = float(m.group(2))
    return out


def test_firmware_board_facts_match_profiles():
    d = _defines()
    assert d["UNITS_VREF_MV"] / 1000 == pytest.approx(profiles.VREF, rel=1e-12)
    assert d["UNITS_ADC_STEPS"] == profiles.ADC_STEPS
    assert d["UNITS_GYRO_MV_PER_DPS"] / 1000 == pytest.approx(profiles.GYRO_SENSITIVITY_V_PER_DPS, rel=1e-12)
    assert d["UNITS_G0"] == pytest.approx(profiles.G0, rel=1e-12)
    for name, rg in (("1G5", "1.5"), ("2G", "2"), ("4G", "4"), ("6G", "6")):
        assert d[f"UNITS_ACC_MV_PER_G_{name}"] / 1000 == pytest.approx(profiles.ACC_SENSITIVITY_V_PER_G[rg], rel=1e-12)


def test_summary_scales_are_the_thesis_resolution():
    """One count: 0.977 deg/s and 4.03/5.37/10.7/16.1 mg (the thesis' resolution
    table), so the summary's deviation factors are those."""
    from imu_allan.device.summary import scales

    class H:
        def __init__(self, rg):
            self.range_g, self.extra = rg, {"units": "phys"}

    for rg, mg in (("1.5", 4.03), ("2", 5.37), ("4", 10.7), ("6", 16.1)):
        s = scales(H(rg))
        assert s["ax"].adev == pytest.approx(mg, rel=5e-3)  # the thesis rounds to 3 digits
        assert s["gx"].adev == pytest.approx(0.977, rel=1e-3)
        assert s["gx"].N == pytest.approx(0.9765625 * 60)  # deg/sqrt(h) per count*sqrt(s)
        assert s["gx"].B == pytest.approx(0.9765625 * 3600 / 0.664)  # deg/h per count, /0.664
        assert s["ax"].N == pytest.approx(s["ax"].adev * 9.80665e-3 * 60)  # m/s/sqrt(h)
