"""imu-allan sweep: the power-law dependence, and a short --sim sweep of the real
firmware in simavr, fed by a band-limited gyro model: the N the device's report
gives at each rate is the aliasing law's, the JSON has its promised shape, and
an interrupted sweep resumes."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from imu_allan.analysis import sweep
from imu_allan.noise import sensor

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("BUILD", REPO / "build"))
ELF = BUILD / "avr-atmega168" / "imu-allan.elf"
SIM = BUILD / "host" / "imu-sim"


def _pt(v: float, rel: float) -> dict:
    return {"value": v, "low": v * (1 - rel), "high": v * (1 + rel)}


def test_power_law_recovers_a_known_exponent_and_says_so():
    rng = np.random.default_rng(5)
    fs = [50.0, 100.0, 200.0, 250.0, 500.0, 1000.0]
    # values scattered by their stated 1-sigma (rel 0.05 at 95 % -> sd 2.55 % in log)
    pts = [_pt(0.3 * f**-0.5 * math.exp(rng.normal(0, 0.0255)), 0.05) for f in fs]
    fit = sweep.power_law(fs, pts)
    assert fit["low"] <= -0.5 <= fit["high"]
    assert fit["high"] < 0 and fit["verdict"] == "falls with Fs"
    flat = sweep.power_law(fs, [_pt(2.0 * math.exp(rng.normal(0, 0.0255)), 0.05) for _ in fs])
    assert flat["verdict"] == "independent of Fs" and flat["low"] < 0 < flat["high"]


def test_power_law_flags_a_knee():
    fs = [25.0, 50.0, 100.0, 200.0, 400.0, 800.0, 1600.0]
    # the aliasing law itself: N ~ fs^-1/2 below fc, flat above: not one power law
    pts = [_pt(sensor.aliased_n(0.3, 88.0, f, quantization=False), 0.01) for f in fs]
    fit = sweep.power_law(fs, pts)
    assert fit["power_law_fits"] is False
    assert -0.5 < fit["exponent"] < 0


def _built() -> None:
    if ELF.is_file() and SIM.is_file():
        return
    if "BUILD" in os.environ:
        pytest.skip(f"BUILD={BUILD}: {ELF.name} or imu-sim not built there (run 'make sim')")
    proc = subprocess.run(["make", "-C", str(REPO), "firmware", "sim"], capture_output=True, text=True)
    if proc.returncode != 0 or not (ELF.is_file() and SIM.is_file()):
        pytest.skip(
            "cannot build the firmware and imu-sim here ('make firmware sim' failed: "
            f"{(proc.stderr.strip().splitlines() or ['?'])[-1]})"
        )


def _cli(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(REPO / "host_scripts"), IMU_SIM=str(SIM))
    return subprocess.run([sys.executable, "-m", "imu_allan.cli", *args], capture_output=True, text=True, env=env)


def test_sim_sweep_of_a_band_limited_gyro(tmp_path):
    _built()
    model = {"channels": {ch: {"N": 0.0, "B": 0.0, "K": 0.0, "tempco": 0.0} for ch in sensor.SENSORS}}
    model["channels"]["gx"] = {"N": 0.3, "bandwidth_hz": 88.0, "B": 0.0, "K": 0.0, "offset": 512}
    mf = tmp_path / "gyro.json"
    mf.write_text(json.dumps(model))
    d = tmp_path / "sweep"
    args = [
        "sweep",
        "--sim",
        "--model",
        str(mf),
        "--rates",
        "50,500",
        "--seconds",
        "60",
        "--dir",
        str(d),
        "--fit-from",
        "0.2",
        "--terms",
        "N,B,K",
        "--firmware",
        str(ELF),
        "--json",
    ]
    p = _cli(*args)
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert set(doc["rates"]) == {"50", "500"}
    for k, fs in (("50", 50.0), ("500", 500.0)):
        r = doc["rates"][k]
        assert r["fs_hz"] == fs and r["n"] == int(60 * fs) and r["drops"] == 0
        n = r["channels"]["gx"]["terms"]["N"]
        law = sensor.aliased_n(0.3, 88.0, fs)
        assert n["low"] <= law <= n["high"], (k, n, law)
        assert r["sim"]["N_law"]["gx"] == pytest.approx(law)
    dep = doc["dependence"]["gx"]["N"]
    assert set(dep) >= {"exponent", "low", "high", "verdict"}
    # two rates: exponent of the law between them, in the interval
    want = math.log(sensor.aliased_n(0.3, 88.0, 500) / sensor.aliased_n(0.3, 88.0, 50)) / math.log(500 / 50)
    assert dep["low"] <= want <= dep["high"] and dep["verdict"] == "falls with Fs"

    # resume: the saved rates are not measured again; a new rate is added
    logs = {f: (d / f).stat().st_mtime_ns for f in ("rate-50.log", "rate-500.log")}
    p2 = _cli(*[a if a != "50,500" else "50,100,500" for a in args[:-1]])
    assert p2.returncode == 0, p2.stderr
    assert {f: (d / f).stat().st_mtime_ns for f in logs} == logs
    assert (d / "rate-100.log").is_file()
    assert "Dependence on Fs" in p2.stdout and "Fs = 100 Hz" in p2.stdout
    # other settings in the same directory: refused, one line
    p3 = _cli(*[a if a != "60" else "30" for a in args])
    assert p3.returncode == 2 and "other settings" in p3.stderr and len(p3.stderr.splitlines()) == 1


def test_sim_sweep_identifies_N_on_every_channel_at_the_top_rates(tmp_path):
    """The thesis-like board at 1000 and 1500 Hz (sensors' bands 88-350 Hz, sampled far
    above them): N identified on every channel from the device's own curve, and on the
    channels whose noise spans several ADC counts (ax, ay, gx: the rounding is then the
    1/12 count^2 of white noise the law adds) within 10 % of the aliasing law."""
    _built()
    d = tmp_path / "top"
    args = ["sweep", "--sim", "--rates", "1000,1500", "--seconds", "20", "--dir", str(d)]
    p = _cli(*args, "--firmware", str(ELF), "--json")
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    model = sensor.default_model()
    for k, fs in (("1000", 1000.0), ("1500", 1500.0)):
        r = doc["rates"][k]
        assert r["drops"] == 0
        for ch in sensor.SENSORS:
            n = r["channels"][ch]["terms"]["N"]
            assert n is not None and n["value"] is not None, (k, ch, r["channels"][ch]["fit_notes"])
            c = model.channel(ch)
            law = sensor.aliased_n(c["N"], c["bandwidth_hz"], fs)
            if ch in ("ax", "ay", "gx"):
                assert abs(n["value"] / law - 1) < 0.10, (k, ch, n, law)


def test_sweep_usage_errors(tmp_path):
    p = _cli("sweep", "--sim", "--rates", "100,x", "--seconds", "1")
    assert p.returncode == 2 and "not a list of rates" in p.stderr
    p = _cli(
        "sweep",
        "--port",
        "/dev/null-x",
        "--model",
        "m.json",
        "--rates",
        "100",
        "--seconds",
        "1",
        "--dir",
        str(tmp_path),
    )
    assert p.returncode == 2 and "go with --sim" in p.stderr


def test_port_sweep_drives_the_device_on_a_pty(tmp_path):
    """--port: the simulated board on a pseudo-terminal (imu-sim --pty, real time),
    driven through pyserial exactly as a board on a serial port."""
    _built()
    pytest.importorskip("serial")
    link = tmp_path / "tty"
    proc = subprocess.Popen(
        [str(SIM), "--pty", "--link", str(link), "--synthetic", str(ELF)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        import time

        deadline = time.monotonic() + 10
        while not link.is_symlink():
            assert proc.poll() is None and time.monotonic() < deadline, "imu-sim --pty did not start"
            time.sleep(0.05)
        d = tmp_path / "sweep"
        p = _cli("sweep", "--port", str(link), "--rates", "100,250", "--seconds", "3", "--dir", str(d), "--json")
        assert p.returncode == 0, p.stderr
        doc = json.loads(p.stdout)
        for k, fs in (("100", 100), ("250", 250)):
            r = doc["rates"][k]
            assert r["fs_hz"] == fs and r["n"] >= 0.99 * 3 * fs and r["drops"] == 0
            assert set(r["channels"]) == {"ax", "ay", "az", "gx", "gy", "gz"}
            log = (d / f"rate-{k}.log").read_bytes()
            assert f"ok reset rate={fs}".encode() in log or f"rate={fs}".encode() in log
        assert doc["source"] == f"port:{link}"
        assert "N" in doc["dependence"]["gx"]
    finally:
        proc.terminate()
        proc.wait(timeout=10)
