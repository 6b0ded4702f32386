"""imu-allan thermal: a known temperature coefficient (and a quadratic one) recovered
within the tool's 95 % interval from the sensor model's rows; the block covariance
against simulation; the JSON shape; bad input."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from imu_allan.analysis import thermal
from imu_allan.cli.study import write_model_rows
from imu_allan.noise import sensor
from imu_allan.profiles import parse_scales

TEMPCO = {"ax": 0.3, "ay": -0.2, "az": 0.0, "gx": 0.15, "gy": 0.05, "gz": -0.1}


@pytest.fixture(scope="module")
def capture(tmp_path_factory) -> tuple[Path, sensor.SensorModel]:
    d = tmp_path_factory.mktemp("thermal")
    spec = {
        "temperature": {"start_c": 25.0, "ramp_c_per_s": 0.0, "sine_c": 8.0, "period_s": 1200.0},
        "channels": {ch: {"tempco": v} for ch, v in TEMPCO.items()},
    }
    spec["channels"]["gz"]["tempco2"] = 0.02
    mf = d / "model.json"
    mf.write_text(json.dumps(spec))
    model = sensor.load_model(str(mf))
    rows = d / "cycle.tsv"
    write_model_rows(str(rows), model, 50.0, 50 * 2400, seed=11)
    return rows, model


@pytest.fixture(scope="module")
def doc(capture) -> dict:
    rows, model = capture
    tp = model.doc["temperature"]
    return thermal.study(str(rows), fs=50.0, temp_scale=(tp["c_per_count"], tp["offset_c"]))


def test_known_tempcos_are_within_their_intervals(doc):
    for ch, want in TEMPCO.items():
        tc = doc["channels"][ch]["tempco"]
        assert tc["unit"] == "counts/degC"
        if ch == "gz":
            continue  # quadratic: checked below
        assert tc["low"] <= want <= tc["high"], (ch, tc)
        assert tc["high"] - tc["low"] < 0.1  # and the interval says something


def test_a_quadratic_bias_is_found_and_its_coefficients_recovered(doc):
    gz = doc["channels"]["gz"]
    assert gz["model"] == "quadratic"
    q = gz["quadratic"]
    assert q["c2"]["low"] <= 0.02 <= q["c2"]["high"]
    # the linear coefficient around t_ref: d/dT of -0.1 dT0 + 0.02 dT0^2 at t_ref (dT0 from 25 degC)
    want_c1 = -0.1 + 2 * 0.02 * (q["t_ref"] - 25.0)
    assert q["c1"]["low"] <= want_c1 <= q["c1"]["high"]
    assert doc["channels"]["ax"]["model"] == "linear"


def test_removing_the_thermal_bias_lowers_the_long_tau_deviation(doc):
    gx = doc["channels"]["gx"]
    # at tau ~ 300-600 s the 8 degC cycle times 0.15 counts/degC dominates the raw curve
    before = {round(p["tau_s"], 6): p["dev"] for p in gx["adev_before"] if p["dev"]}
    after = {round(p["tau_s"], 6): p["dev"] for p in gx["adev_after"] if p["dev"]}
    tau = max(t for t in before if t <= 600 and t in after)
    assert after[tau] < 0.5 * before[tau]
    assert set(gx) >= {"tempco", "terms_before", "terms_after", "fit_percent"}
    assert doc["temperature"]["unit"] == "degC" and not doc["temperature"]["one_way"]


def test_noise_terms_against_temperature_hold_the_model_constant(doc):
    """The model's N does not change with temperature.  Each channel's N slope against the
    segments' temperature, recomputed here (weighted least squares, weights from the
    segments' 95 % intervals), is a standard normal z under that truth; six 95 % intervals
    all holding 0 would fail one run in four by chance, so the six are judged together:
    sum z^2 is chi-squared with 6 degrees of freedom, rejected above its 99 % point (a run
    of a correct tool fails 1 % of the time, by design)."""
    z2 = []
    for ch in TEMPCO:
        bt = doc["channels"][ch]["terms_by_temperature"]
        assert len(bt["temperature"]) == 3 and len(bt["N"]) == 3
        t = np.array(bt["temperature"], dtype=np.float64)
        y = np.array([v["value"] for v in bt["N"]])
        sd = np.array([(v["high"] - v["low"]) / (2 * 1.959963984540054) for v in bt["N"]])
        w = 1.0 / sd**2
        tc = t - np.average(t, weights=w)
        slope = float(np.sum(w * tc * y) / np.sum(w * tc * tc))
        assert bt["N_slope"]["value"] == pytest.approx(slope, rel=1e-6, abs=1e-12), (ch, bt["N_slope"])
        z2.append(slope**2 * float(np.sum(w * tc * tc)))  # (slope / its sd)^2
        n_all = doc["channels"][ch]["terms_after"]["N"]["value"]
        assert all(abs(v["value"] / n_all - 1) < 0.05 for v in bt["N"])
    from scipy import stats

    assert sum(z2) < stats.chi2.ppf(0.99, len(z2)), dict(zip(TEMPCO, np.round(np.sqrt(z2), 2)))


def test_linear_slope_finds_a_known_slope():
    x = [10.0, 20.0, 30.0, 40.0]
    vals = [{"value": 1.0 + 0.01 * t, "low": 1.0 + 0.01 * t - 0.02, "high": 1.0 + 0.01 * t + 0.02} for t in x]
    sl = thermal.linear_slope(x, vals)
    assert sl["low"] < 0.01 < sl["high"] and sl["verdict"] == "grows with temperature"
    assert sl["value"] == pytest.approx(0.01)


def test_block_covariance_of_a_random_walk_matches_simulation():
    K, D, nb = 0.2, 2.0, 6
    centres = (np.arange(nb) + 0.5) * D
    S = thermal.block_covariance(centres, D, {"K": K})
    rng = np.random.default_rng(0)
    L = 200
    steps = rng.standard_normal((4000, nb * L)) * K * math.sqrt(D / L)
    w = np.cumsum(steps, axis=1)
    means = w.reshape(4000, nb, L).mean(axis=2)
    emp = np.cov(means.T)
    assert np.allclose(emp, S, rtol=0.12, atol=0.02 * S.max())


def test_block_covariance_of_white_noise_is_diagonal():
    S = thermal.block_covariance(np.arange(3) * 5.0 + 2.5, 5.0, {"N": 0.4})
    assert np.allclose(S, np.eye(3) * 0.16 / 5.0)


@pytest.fixture(scope="module")
def short_cycle(capture, tmp_path_factory) -> Path:
    """A third of the temperature cycle (400 s at 50 Hz) of the same model."""
    _, model = capture
    rows = tmp_path_factory.mktemp("thermal-short") / "short-cycle.tsv"
    write_model_rows(str(rows), model, 50.0, 20_000, seed=2)
    return rows


def test_cli_json_shape_and_errors(short_cycle, run_cli, tmp_path):
    rows = short_cycle
    rc, out, err = run_cli("thermal", rows, "--fs", "50", "--json")
    assert rc == 0, err
    d = json.loads(out)
    gx = d["channels"]["gx"]
    assert set(gx["tempco"]) == {"value", "low", "high", "unit"} and gx["tempco"]["unit"] == "counts/code"
    assert "N" in gx["terms_before"] and "N" in gx["terms_after"]
    rc, _, err = run_cli("thermal", rows)
    assert rc == 2 and "--fs" in err and len(err.splitlines()) == 1
    short = tmp_path / "short.tsv"
    short.write_text("500\t500\t500\t500\t500\t500\t63\n" * 10)
    rc, _, err = run_cli("thermal", short, "--fs", "50")
    assert rc == 2 and "too few" in err
    csv = tmp_path / "no-temp.csv"
    csv.write_text("t,ax,ay,az,gx,gy,gz\n" + "".join(f"{i * 0.02:.2f},1,2,3,4,5,6\n" for i in range(2000)))
    rc, _, err = run_cli("thermal", csv)
    assert rc == 2 and "no temperature column" in err and len(err.splitlines()) == 1
    rc, _, err = run_cli("thermal", rows, "--fs", "50", "--temp-scale", "abc")
    assert rc == 2 and "C_PER_COUNT" in err


def test_a_temperature_that_does_not_vary_gets_no_fit_and_says_so(tmp_path: Path, run_cli) -> None:
    """A still temperature (only its sensor's noise): no tempco (a fit would print 0 [0, 0], a
    false measured zero), one sentence why, exit status 0."""
    spec = {"temperature": {"start_c": 25.0, "ramp_c_per_s": 0.0, "sine_c": 0.0, "period_s": 1200.0}}
    mf = tmp_path / "model.json"
    mf.write_text(json.dumps(spec))
    rows = tmp_path / "still.tsv"
    write_model_rows(str(rows), sensor.load_model(str(mf)), 50.0, 50 * 600, seed=3)
    codes, _, _ = thermal.read_with_temperature(str(rows))
    assert codes[6].max() - codes[6].min() <= 4  # a still temperature: its sensor's noise only
    rc, out, err = run_cli("thermal", rows, "--fs", "50")
    assert rc == 0, err
    assert re.search(r"temperature does not vary \(range 0\.\d+ code, under 3 codes\): no thermal fit", out)
    assert "tempco" not in out
    rc, out, err = run_cli("thermal", rows, "--fs", "50", "--json")
    assert rc == 0, err
    doc = json.loads(out)
    assert doc["fitted"] is False and doc["channels"] == {}


def test_scale_gives_the_tempco_in_the_sensors_units(capture, short_cycle) -> None:
    """--scale gx=0.5 (deg/s per count): gx's tempco is half its value in counts,
    the other channels unchanged (an exact relation: a third of the cycle shows it)."""
    _, model = capture
    rows = short_cycle
    tp = model.doc["temperature"]
    ts = (tp["c_per_count"], tp["offset_c"])
    base = thermal.study(str(rows), fs=50.0, temp_scale=ts, segments=1)
    scaled = thermal.study(str(rows), fs=50.0, temp_scale=ts, segments=1, scales=parse_scales(["gx=0.5"]))
    assert scaled["channels"]["gx"]["tempco"]["unit"] == "deg/s/degC"
    assert scaled["channels"]["gx"]["tempco"]["value"] == pytest.approx(
        0.5 * base["channels"]["gx"]["tempco"]["value"], rel=1e-9
    )
    assert scaled["channels"]["ax"]["tempco"] == base["channels"]["ax"]["tempco"]
