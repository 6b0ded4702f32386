"""The over-bounding white + random-walk pair (analysis/overbound.py) and the
estimators' files that carry it (Kalibr, OpenVINS, VINS-Fusion).

Graded on sensors from an independent generator written here from the
textbook formulas: Gaussian white noise, Kasdin's fractional differencing for
flicker (bias instability B; N. J. Kasdin, Proc. IEEE 83, 1995), the AR(1)
recursion for a Gauss-Markov hump, a cumulative sum for the rate random walk.
The measured curve is checked against allantools, its upper 95 % limit against
scipy's chi-squared quantiles, and "smallest" against scipy's linear programme."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import optimize, signal
from scipy import stats as sps

from imu_allan.analysis import overbound
from imu_allan.analysis.pipeline import Options, analyze
from imu_allan.profiles import build_profile
from imu_allan.sources.detect import SampleSource, Source

allantools = pytest.importorskip("allantools")

FS = 100.0
N_SAMPLES = 1 << 18  # 44 min at 100 Hz: the default horizon is 100 s


def _sensor(seed: int, n_: float, b: float, gm: tuple[float, float], k: float) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n = N_SAMPLES
    x = rng.standard_normal(n) * n_ * math.sqrt(FS)
    if b:
        j = np.arange(1, n)
        h = np.concatenate(([1.0], np.cumprod((j - 1 + 0.5) / j)))
        x += signal.fftconvolve(rng.standard_normal(n) * b, h)[:n]
    sigma, tc = gm
    if sigma:
        phi = math.exp(-1.0 / (FS * tc))
        x += signal.lfilter([1.0], [1.0, -phi], rng.standard_normal(n) * sigma * math.sqrt(1 - phi * phi))
    if k:
        x += np.cumsum(rng.standard_normal(n) * k / math.sqrt(FS))
    return x


SENSORS = {
    # white + bias instability + a Gauss-Markov hump near 40 s (deg/s)
    "flicker_and_hump": dict(n_=0.05, b=0.004, gm=(0.02, 20.0), k=0.0),
    # white + a short Gauss-Markov hump + rate random walk (K fitted: its factor checked)
    "hump_and_walk": dict(n_=0.03, b=0.0, gm=(0.03, 2.0), k=2e-3),
}


def _doc(x: np.ndarray, horizon=None) -> dict:
    ss = SampleSource("csv", "generated", ["gx"], lambda: iter([x[None, :]]), False, fs=FS)
    prof = build_profile(None, {"gx": (1.0, "deg/s")})
    opts = Options(fs=FS, model=False, extra_curves=False, horizon=horizon)
    return analyze(Source("generated", ss, None), prof, opts).doc


@pytest.mark.parametrize("name", sorted(SENSORS))
def test_pair_covers_the_upper_limit_to_the_horizon_and_touches_it(name: str) -> None:
    x = _sensor(7, **SENSORS[name])
    doc = _doc(x)
    ch = doc["channels"]["gx"]
    ob = ch["overbound"]
    assert ob["horizon_s"] == pytest.approx(min(100.0, 0.1 * N_SAMPLES / FS))
    pts = [p for p in ch["fit"]["octave_points"] if 1 / FS <= p["tau_s"] <= ob["horizon_s"] + 1e-9]
    tau = np.array([p["tau_s"] for p in pts])
    # the measured curve is allantools' overlapping ADEV; its upper limit the chi-squared one
    (t_at, dev_at, *_) = allantools.oadev(x, rate=FS, data_type="freq", taus=tau)
    np.testing.assert_allclose(t_at, tau)
    np.testing.assert_allclose([p["dev"] for p in pts], dev_at, rtol=1e-9)
    edf = np.array([p["edf"] for p in pts])
    upper = dev_at * np.sqrt(edf / sps.chi2.ppf(0.025, edf))
    np.testing.assert_allclose([p["high"] for p in pts], upper, rtol=1e-9)
    pair = np.sqrt(ob["N"] ** 2 / tau + ob["K"] ** 2 * tau / 3)
    ratio = pair / upper
    assert np.all(ratio >= 1 - 1e-9), ratio  # at or above at every octave tau to the horizon
    assert ratio.min() <= 1.25  # and tight somewhere (here it touches: the LP's vertex)
    assert tau.max() >= 0.5 * ob["horizon_s"]
    # the unmodelled effects make the pair larger than the fit's N and K
    if ch["terms"]["N"]:
        assert ob["inflation_N"] == pytest.approx(ob["N"] / ch["terms"]["N"]["value"], rel=1e-12)
        assert ob["inflation_N"] >= 1.0
    if SENSORS[name]["k"]:
        assert ch["terms"]["K"] is not None
        assert ob["inflation_K"] == pytest.approx(ob["K"] / ch["terms"]["K"]["value"], rel=1e-12)
        assert ob["inflation_K"] > 1.5  # the hump below the random walk's line must be covered
    assert ob["why"] and ob["touches_s"]
    si = ch["si"]["overbound"]
    assert si["N"] == pytest.approx(ob["N"] * math.pi / 180, rel=1e-12)
    assert si["K"] == pytest.approx(ob["K"] * math.pi / 180, rel=1e-12)


def test_smallest_is_the_linear_programmes_optimum() -> None:
    """The vertex enumeration gives scipy's LP optimum: minimise the mean ratio of
    the pair's AVAR to the limit subject to covering every point."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        tau = 2.0 ** np.arange(-6, 8)
        upper = (0.01 / tau + 1e-6 * tau + 1e-4 * rng.lognormal(0, 0.5) * np.exp(-((np.log(tau) - 2) ** 2))) * (
            1 + 0.2 * rng.random(tau.size)
        )
        a, b = overbound.overbound_pair(tau, upper)
        ca, cb = 1 / tau, tau / 3
        res = optimize.linprog(
            [np.sum(ca / upper), np.sum(cb / upper)],
            A_ub=-np.stack([ca, cb], axis=1),
            b_ub=-upper,
            bounds=[(0, None), (0, None)],
            method="highs",
        )
        assert res.status == 0
        obj = np.sum(ca / upper) * a + np.sum(cb / upper) * b
        assert obj == pytest.approx(res.fun, rel=1e-7)
        assert np.all(ca * a + cb * b >= upper * (1 - 1e-12))


def test_horizon_option_limits_the_points() -> None:
    x = _sensor(2, **SENSORS["hump_and_walk"])
    ob = _doc(x, horizon=5.0)["channels"]["gx"]["overbound"]
    assert ob["horizon_s"] == 5.0 and ob["tau_max_s"] <= 5.0


def _keys(text: str) -> dict[str, float]:
    out = {}
    for ln in text.splitlines():
        body = ln.split("#")[0].strip()
        if ":" in body and not body.endswith(":"):
            k, v = body.split(":", 1)
            try:
                out[k.strip()] = float(v)
            except ValueError:
                out[k.strip()] = v.strip()
    return out


def test_estimator_files_carry_the_chosen_pair(tmp_path: Path, run_cli) -> None:
    rng = np.random.default_rng(4)
    n = 40000
    codes = 512 + rng.normal(0, 3, (7, n))
    codes[4] += np.cumsum(rng.normal(0, 0.03, n))  # gy: a random walk to over-bound
    rows = tmp_path / "r.tsv"
    np.savetxt(rows, np.rint(codes.T).astype(int), fmt="%d", delimiter="\t")
    base = ("analyze", rows, "--fs", "100", "--no-model", "--no-warmup")
    import json

    rc, out, err = run_cli(*base, "--json")
    assert rc == 0, err
    doc = json.loads(out)
    rc, out, err = run_cli(*base, "--json", "--horizon", "5", "--channels", "gy")
    assert rc == 0, err
    ob5 = json.loads(out)["channels"]["gy"]["overbound"]
    assert ob5["horizon_s"] == 5 and ob5["tau_max_s"] <= 5
    for noise in ("fitted", "overbound"):
        k, o, v = (tmp_path / f"{noise}.{e}.yaml" for e in ("k", "o", "v"))
        rc, _, err = run_cli(*base, "--noise", noise, "--kalibr", k, "--openvins", o, "--vins", v)
        assert rc == 0, err
        if noise == "overbound":
            n_g = max(doc["channels"][c]["si"]["overbound"]["N"] for c in ("gx", "gy", "gz"))
            k_a = max(doc["channels"][c]["si"]["overbound"]["K"] for c in ("ax", "ay", "az"))
        else:
            n_g = max(doc["channels"][c]["si"]["terms"]["N"]["value"] for c in ("gx", "gy", "gz"))
            k_a = None
        kal, ov, vi = (_keys(p.read_text()) for p in (k, o, v))
        for text in (k.read_text(), o.read_text(), v.read_text()):
            assert f"Pair carried: {noise.upper()}" in text
        assert kal["gyroscope_noise_density"] == pytest.approx(n_g, rel=1e-6)
        assert ov["gyroscope_noise_density"] == pytest.approx(n_g, rel=1e-6)
        assert vi["gyr_n"] == pytest.approx(n_g * math.sqrt(100), rel=1e-6)  # discrete: per sample
        if k_a is not None:
            assert kal["accelerometer_random_walk"] == pytest.approx(k_a, rel=1e-6)
            assert vi["acc_w"] == pytest.approx(k_a * math.sqrt(100), rel=1e-6)
        assert kal["update_rate"] == ov["update_rate"] == 100 and kal["rostopic"] == ov["rostopic"] == "/imu0"
        assert "\nimu0:\n  accelerometer_noise_density:" in o.read_text()
        assert "# rate: 100 Hz" in v.read_text()
