"""The continuous sensor model (sensor.py): its processes sampled at any step,
the aliasing law of a band-limited gyro sampled across and above its bandwidth,
the ADC's sampling instants, model files."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from imu_allan.errors import InputError
from imu_allan.noise import sensor, terms
from imu_allan.stats import edf
from imu_allan.stats.allan import octave_oavar


def _only(**kw: float) -> dict[str, float]:
    return {"N": 0.0, "bandwidth_hz": 88.0, "gm_sigma": 0.0, "gm_tau": 1.0, "K": 0.0, "B": 0.0, **kw}


def test_the_lowpassed_white_noise_has_the_ou_variance_and_autocorrelation_at_every_step():
    """An OU process (time constant T = 1 / (2 pi f_c), variance pi f_c N^2) sampled every h:
    variance pi f_c N^2 and lag-k correlation exp(-k h / T), whatever h."""
    N, fc, n = 0.3, 88.0, 200_000
    sigma2, T = math.pi * fc * N * N, 1.0 / (2 * math.pi * fc)
    for fs in (100.0, 250.0, 1500.0):
        x = sensor.channel_model(_only(N=N, bandwidth_hz=fc)).simulate(n, fs, 1)
        a = math.exp(-1.0 / (fs * T))
        # the variance of a sample variance of an AR(1) series: 2 sigma^4 (1 + a^2) / (1 - a^2) / n
        sd_var = sigma2 * math.sqrt(2 * (1 + a * a) / (1 - a * a) / n)
        assert abs(x.var() - sigma2) < 4 * sd_var, fs
        r1 = np.corrcoef(x[:-1], x[1:])[0, 1]
        assert abs(r1 - a) < 4 * math.sqrt((1 - a * a) ** 2 / n) * 3 + 1e-3, fs
        r3 = np.corrcoef(x[:-3], x[3:])[0, 1]
        assert abs(r3 - a**3) < 0.02, fs


def test_walk_variance_grows_as_k2_t():
    K, fs = 0.5, 100.0
    paths = np.stack([sensor.channel_model(_only(K=K)).simulate(1000, fs, s) for s in range(400)])
    v = paths[:, -1].var()
    assert abs(v - K * K * 10.0) < 0.25 * K * K * 10.0


def test_board_blocks_must_be_consecutive():
    b = sensor.Board(sensor.default_model(), 100.0, 100, seed=1)
    b.codes(0, 10)
    with pytest.raises(ValueError, match="consecutive"):
        b.codes(20, 10)


def test_aliasing_law_is_the_poisson_sum_of_the_lowpass_psd():
    S0, fc = 2.0, 88.0
    for fs in (20.0, 100.0, 1000.0):
        direct = sum(S0 / (1 + (m * fs / fc) ** 2) for m in range(-200_000, 200_001))
        assert sensor.aliased_density(S0, fc, fs) == pytest.approx(direct, rel=1e-4)


def _n_read(x: np.ndarray, fs: float, tau_min: float) -> terms.Term:
    r = octave_oavar(x, nonoverlapping=False)
    n = x.size
    efn = edf.edf_function(r.ms, np.full(r.ms.size, n + 1), r.stride)
    fit = terms.fit_terms(r.ms / fs, r.oavar[:, 0], efn, mask=r.ms / fs >= tau_min)
    return fit.terms["N"]


@pytest.mark.parametrize("fs", [25, 100, 400])
def test_band_limited_gyro_n_follows_the_aliasing_law(fs):
    """A gyro of white density N through an 88 Hz low-pass, sampled at fs below,
    near and above twice its bandwidth: the N fitted on the -1/2 slope is the law's."""
    model = sensor.default_model()
    for ch in sensor.SENSORS:
        model.channel(ch).update(N=0.0, B=0.0, K=0.0, tempco=0.0)
    model.channel("gx").update(N=0.3, bandwidth_hz=88.0, offset=512.0)
    n = int(400 * fs)
    codes = np.concatenate(list(sensor.Board(model, fs, n, seed=fs).blocks()), axis=1)
    t = _n_read(codes[3].astype(np.float64), fs, tau_min=0.2)
    law = sensor.aliased_n(0.3, 88.0, fs)
    assert t.value is not None
    assert t.low <= law <= t.high, (fs, t.low, law, t.high)
    # and the law is far from the unaliased N where fs is low: the test can fail
    if fs == 25:
        assert law > 3 * 0.3


def test_sigma_of_the_samples_does_not_depend_on_the_rate():
    model = sensor.default_model()
    g = model.channel("gx")
    want = math.sqrt(sensor.lowpass_sigma(g["N"], g["bandwidth_hz"]) ** 2 + 1 / 12)
    for fs in (50, 1000):
        codes = np.concatenate(list(sensor.Board(model, fs, 40_000, seed=3).blocks()), axis=1)
        assert codes[3].std() == pytest.approx(want, rel=0.05)


def test_columns_are_sampled_after_the_tick_in_scan_order():
    m = sensor.default_model()
    off = m.offsets_s()
    assert np.allclose(np.diff(off), 13 / 156_250)  # free running: 13 ADC clocks a conversion (adc.c)
    assert off[0] == pytest.approx(2.5 / 156_250)
    assert off[-1] < 1 / 1000  # the scan ends within the fastest period
    t = sensor.sample_instants(m, 200.0, 10, 3)
    assert t.shape == (7, 3) and t[0, 0] == pytest.approx(10 / 200 + off[0])


def test_average_of_m_scans_lowers_the_aliased_noise():
    model = sensor.default_model()
    one = np.concatenate(list(sensor.Board(model, 100, 20_000, seed=4).blocks()), axis=1)
    avg = np.concatenate(list(sensor.Board(model, 100, 20_000, seed=4, average=8).blocks()), axis=1)
    # 8 scans 1.25 ms apart: white-ish samples averaged, variance ~1/8 (the 88 Hz low-pass
    # correlates neighbours, so a little more): well below half
    assert avg[3].astype(float).var() < 0.5 * one[3].astype(float).var()


def test_temperature_column_reads_the_profile(tmp_path):
    p = tmp_path / "m.json"
    p.write_text(json.dumps({"temperature": {"start_c": 20.0, "ramp_c_per_s": 0.1, "noise": 0.0}}))
    m = sensor.load_model(str(p))
    codes = np.concatenate(list(sensor.Board(m, 10, 1000, seed=1).blocks()), axis=1)
    t_c = codes[6] * m.doc["temperature"]["c_per_count"]
    want = 20.0 + 0.1 * np.arange(1000) / 10
    assert np.max(np.abs(t_c - want)) <= m.doc["temperature"]["c_per_count"] / 2 + 1e-3


def test_model_file_errors_name_the_file_and_key(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text(json.dumps({"channels": {"gx": {"NN": 1}}}))
    with pytest.raises(InputError, match="bad.json.*channels.gx.NN"):
        sensor.load_model(str(p))
    p.write_text("{\n oops")
    with pytest.raises(InputError, match="bad.json' line 2"):
        sensor.load_model(str(p))
    p.write_text(json.dumps({"channels": {"gq": {}}}))
    with pytest.raises(InputError, match="unknown channel 'gq'"):
        sensor.load_model(str(p))
    p.write_text(json.dumps({"channels": {"gx": {"bandwidth_hz": 0}}}))
    with pytest.raises(InputError, match="bandwidth_hz must be positive"):
        sensor.load_model(str(p))


def test_gen_model_writes_the_model_rows(tmp_path):
    import os
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    mf = tmp_path / "m.json"
    mf.write_text(json.dumps({"temperature": {"ramp_c_per_s": 0.01}}))
    out = tmp_path / "g.tsv"
    env = dict(os.environ, PYTHONPATH=str(repo / "host_scripts"))
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "imu_allan.cli",
            "gen",
            "--model",
            str(mf),
            "--fs",
            "250",
            "-n",
            "3000",
            "--seed",
            "4",
            "-o",
            str(out),
        ],
        capture_output=True,
        text=True,
        env=env,
    )
    assert p.returncode == 0, p.stderr
    from imu_allan.sources.rows import read_rows

    got = read_rows(str(out))
    want = sensor.Board(sensor.load_model(str(mf)), 250.0, 3000, seed=4).codes(0, 3000)
    assert np.array_equal(got, want)
    p = subprocess.run(
        [sys.executable, "-m", "imu_allan.cli", "gen", "--model", str(tmp_path / "none.json"), "-o", str(out)],
        capture_output=True,
        text=True,
        env=env,
    )
    assert p.returncode == 2 and "none.json" in p.stderr and len(p.stderr.splitlines()) == 1


@pytest.mark.parametrize("order,fc", [(1, 5.0), (2, 40.0), (2, 240.0)])
def test_the_band_limit_psd_is_the_filters_frequency_response(order, fc):
    """LP's PSD, 2 N^2 |H|^2 / H(0)^2, with H evaluated without scipy.signal, against
    scipy.signal.freqz of the same filter (one pole, or a two-pole Butterworth, at 1 kHz)."""
    from scipy import signal

    from imu_allan.noise.filters import lowpass_filter
    from imu_allan.noise.processes import LP

    fs, lp = 1000.0, LP(N=0.3, fc=fc, order=order)
    b, a = lowpass_filter(fc, fs, order)
    f = np.linspace(0.0, fs / 2, 257)
    _, h = signal.freqz(b, a, worN=f, fs=fs)
    dc = np.sum(b) / np.sum(a)
    assert lp.psd(f, fs) == pytest.approx(2 * 0.3**2 * np.abs(h) ** 2 / dc**2, rel=1e-9, abs=1e-15)
