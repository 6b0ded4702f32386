"""`imu-allan analyze`: inputs chosen by content, units, the JSON contract,
the exports (CSV, Kalibr, imu_utils, PNG) and one-line errors."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import line, raw_row, report_lines, thesis_like, write_rows

from imu_allan.profiles import G0, thesis_profile

CH = ("ax", "ay", "az", "gx", "gy", "gz")
ACC_COUNT = thesis_profile().scale("ax").per_count  # m/s^2 per count at 1.5 g
GYRO_COUNT = thesis_profile().scale("gx").per_count  # deg/s per count


@pytest.fixture(scope="module")
def rows() -> np.ndarray:
    return thesis_like(8192, 3)


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory, rows: np.ndarray) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("an")
    data = write_rows(d / "rows.txt", rows)
    log = d / "dev.log"
    log.write_bytes(b"noise before\r\n" + b"".join(report_lines(rows, 12, extra=",mode=allan,range=1.5")))
    cap = bytearray(b"partial row\r\n")  # a capture in mode 'both': rows, count lines, a report
    for i, r in enumerate(rows):
        cap += raw_row(r)
        if (i + 1) % 100 == 0:
            cap += line(f"C,{i + 1},0")
    cap += b"".join(report_lines(rows, 12, extra=",mode=both,range=1.5"))
    (d / "both.log").write_bytes(bytes(cap))
    return {"rows": data, "log": log, "both": d / "both.log", "dir": d}


def _json(run_cli, *args) -> dict:
    rc, out, err = run_cli("analyze", *args, "--json")
    assert rc == 0, err
    return json.loads(out)


def _white_n(rows: np.ndarray, c: int, scale: float, fs: float = 100.0) -> float:
    """N of white-dominated data: the lag-1 Allan deviation times sqrt(tau0)."""
    x = rows[:, c].astype(float) * scale
    return math.sqrt(np.mean(np.diff(x) ** 2) / 2) / math.sqrt(fs)


def test_help_is_for_newcomers(run_cli) -> None:
    rc, out, _ = run_cli("analyze", "--help")
    assert rc == 0 and out.startswith("usage: imu-allan analyze")
    for phrase in (
        "bias instability",
        "rate random walk",
        "--fs HZ",
        "--scale",
        "Kalibr",
        "examples:",
        "95 %",
        "docs/analysis.md",
        "exit status",
    ):
        assert phrase in out, phrase
    rc, out, _ = run_cli("--help")
    assert "analyze" in out


def test_rows_json_contract(run_cli, files, rows) -> None:
    doc = _json(run_cli, files["rows"], "--fs", "100", "--no-model")
    assert set(doc["channels"]) == set(CH)
    assert doc["source"]["kind"] == "rows" and doc["source"]["n"] == 8192 and doc["source"]["fs_hz"] == 100
    for c in CH:
        ch = doc["channels"][c]
        assert ch["unit"] == ("m/s^2" if c[0] == "a" else "deg/s")
        # the IEEE 952 five always; a band limit LP, Gauss-Markov processes GM1, GM2...
        # and an oscillation SIN when fitted
        assert set(ch["terms"]) >= {"N", "B", "K", "Q", "R"}
        assert all(k in ("LP", "SIN") or re.fullmatch(r"GM\d", k) for k in set(ch["terms"]) - {"N", "B", "K", "Q", "R"})
        for _k, t in ch["terms"].items():
            assert t is None or (set(t) >= {"value", "low", "high"} and t["low"] <= t["value"] <= t["high"])
        assert ch["term_units"]["N"] == f"{ch['unit']}*sqrt(s)" and ch["term_units"]["K"] == f"{ch['unit']}/sqrt(s)"
        pts = ch["curve"]
        assert [p["tau_s"] for p in pts][:3] == [0.01, 0.02, 0.04]
        assert all(p["low"] <= p["dev"] <= p["high"] for p in pts)
        assert {"adev", "mdev", "hdev"} <= set(ch["curves"])
        assert ch["psd"]["f_hz"] and ch["psd"]["unit"] == f"({ch['unit']})^2/Hz"
    # N against a direct estimate, in SI and in the gyro's rad/s
    for c, scale in (("ax", ACC_COUNT), ("gx", GYRO_COUNT)):
        n = doc["channels"][c]["terms"]["N"]["value"]
        assert n == pytest.approx(_white_n(rows, CH.index(c), scale), rel=0.05)
    gx = doc["channels"]["gx"]
    assert gx["si"]["unit"] == "rad/s"
    assert gx["si"]["terms"]["N"]["value"] == pytest.approx(gx["terms"]["N"]["value"] * math.pi / 180)


def test_missing_fs_is_one_line(run_cli, files) -> None:
    rc, out, err = run_cli("analyze", files["rows"])
    assert rc == 2 and out == ""
    assert err == "imu-allan analyze: the sample rate is unknown: give --fs HZ (a rows file does not carry it)\n"


def test_device_log_alone(run_cli, files, rows) -> None:
    doc = _json(run_cli, files["log"], "--no-model")
    assert doc["source"]["kind"] == "device-log" and doc["source"]["fs_hz"] == 100
    gx = doc["channels"]["gx"]
    assert len(gx["curve"]) == 12 and gx["fit"]["statistic"] == "adev (device)"
    assert gx["terms"]["N"]["value"] == pytest.approx(_white_n(rows, 3, GYRO_COUNT), rel=0.05)
    rc, out, _ = run_cli("analyze", files["log"], "--no-model")
    words = " ".join(out.split())  # the text wraps at 80 columns
    assert rc == 0 and "device log (on-device results only)" in words and "deg/sqrt(h)" in out


def test_rows_with_device_log_agree(run_cli, files) -> None:
    doc = _json(run_cli, files["rows"], "--fs", "100", "--device", files["log"], "--no-model")
    for c in CH:
        a = doc["channels"][c]["device"]["agreement"]
        assert a["checked"] == 12 and a["within"] >= 11
    rc, out, _ = run_cli("analyze", files["rows"], "--fs", "100", "--device", files["log"], "--no-model")
    assert "device vs host: " in out


def test_capture_in_mode_both(run_cli, files) -> None:
    doc = _json(run_cli, files["both"], "--no-model")
    assert doc["source"]["kind"] == "capture" and doc["source"]["n"] == 8192
    assert doc["source"]["fs_hz"] == 100  # from the report's header
    assert doc["channels"]["az"]["device"]["agreement"]["checked"] == 12


def test_fs_and_range_must_match_the_header(run_cli, files) -> None:
    rc, _, err = run_cli("analyze", files["log"], "--fs", "200")
    assert rc == 2 and err == "imu-allan analyze: --fs 200 contradicts the device header (fs=100 Hz)\n"
    rc, _, err = run_cli("analyze", files["log"], "--range", "4")
    assert rc == 2 and "contradicts the device header (range=1.5 g)" in err


def test_range_changes_the_accelerometer_scale(run_cli, files) -> None:
    a = _json(run_cli, files["rows"], "--fs", "100", "--no-model", "--channels", "ax")
    b = _json(run_cli, files["rows"], "--fs", "100", "--no-model", "--channels", "ax", "--range", "6")
    assert list(a["channels"]) == ["ax"]
    ratio = b["channels"]["ax"]["terms"]["N"]["value"] / a["channels"]["ax"]["terms"]["N"]["value"]
    assert ratio == pytest.approx(0.8 / 0.2)


def test_csv_with_time_and_units(run_cli, tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    n, fs = 6000, 200.0
    g = rng.standard_normal((n, 3)) * 0.01  # rad/s, white: N = 0.01 / sqrt(200) rad/s*sqrt(s)
    a = rng.standard_normal((n, 3)) * 0.002  # g
    t = 1000.0 + np.arange(n) / fs
    p = tmp_path / "imu.csv"
    with open(p, "w") as f:
        f.write("# exported\ntime,acc_x (g),acc_y (g),acc_z (g),gyro_x [rad/s],gyro_y [rad/s],gyro_z [rad/s],temp\n")
        for i in range(n):
            f.write(f"{t[i]:.6f}," + ",".join(f"{v:.8f}" for v in (*a[i], *g[i])) + ",25.0\n")
    doc = _json(run_cli, p, "--no-model")
    assert doc["source"]["kind"] == "csv" and doc["source"]["fs_hz"] == pytest.approx(fs)
    gx = doc["channels"]["gx"]
    assert gx["unit"] == "deg/s"
    want = 0.01 / math.sqrt(fs) * 180 / math.pi
    assert gx["terms"]["N"]["value"] == pytest.approx(want, rel=0.05)
    assert doc["channels"]["ax"]["terms"]["N"]["value"] == pytest.approx(0.002 * G0 / math.sqrt(fs), rel=0.05)
    assert any("time column" in s for s in doc["notes"])


def test_csv_without_units_asks_for_a_scale(run_cli, tmp_path: Path) -> None:
    p = tmp_path / "x.csv"
    p.write_text("gx,gy\n" + "".join(f"{0.001 * i:.4f},{0.5 + 0.001 * i:.4f}\n" for i in range(200)))
    rc, out, err = run_cli("analyze", p, "--fs", "50")
    assert rc == 2 and out == "" and err.count("\n") == 1
    assert "not 10-bit ADC codes" in err and "--scale gx=1rad/s" in err
    doc = _json(run_cli, p, "--fs", "50", "--scale", "gx=1rad/s,gy=0.5", "--no-model")
    assert doc["channels"]["gx"]["scale_per_count"] == pytest.approx(180 / math.pi)
    assert doc["channels"]["gy"]["scale_per_count"] == 0.5


def test_generic_scale_on_codes(run_cli, files) -> None:
    doc = _json(run_cli, files["rows"], "--fs", "100", "--scale", "gz=0.07", "--no-model")
    assert doc["profile"]["name"] == "generic"
    assert doc["channels"]["gz"]["unit"] == "deg/s" and doc["channels"]["gz"]["scale_per_count"] == 0.07
    assert doc["channels"]["gx"]["unit"] == "count"


@pytest.mark.parametrize(
    "content,message",
    [
        (b"", "is empty"),
        (b"\x00\x01\x02\x03" * 100, "binary data"),
        (b"1 2 3 4 5\n6 7 8 9 10\n", "5 numeric columns and no header"),
        (b"# only a comment\n\n", "holds no data"),
        (b"foo,bar\n1,2\n", "no column named like a sensor channel"),
        (b"ax,ay\n1,2\n3,x\n", "line 3"),
    ],
)
def test_bad_inputs_are_one_line(run_cli, tmp_path: Path, content: bytes, message: str) -> None:
    p = tmp_path / "in.dat"
    p.write_bytes(content)
    rc, out, err = run_cli("analyze", p, "--fs", "100", "--scale", "ax=1,ay=1")
    assert rc == 2 and out == "" and err.count("\n") == 1 and message in err, err


@pytest.mark.parametrize(
    "argv,message",
    [
        (("--channels", "gq"), "unknown channel 'gq'"),
        (("--scale", "gx=abc"), "expected CH=VALUE[UNIT]"),
        (("--scale", "gx=1m/s^2"), "not a gyro rate unit"),
        (("--scale", "gx=-1"), "the scale must be a positive number"),
    ],
)
def test_bad_options_are_one_line(run_cli, files, argv, message) -> None:
    rc, out, err = run_cli("analyze", files["rows"], "--fs", "100", *argv)
    assert rc == 2 and out == "" and err.count("\n") == 1 and message in err, err


def test_exports(run_cli, files) -> None:
    d = files["dir"]
    rc, out, err = run_cli(
        "analyze",
        files["rows"],
        "--fs",
        "100",
        "--csv",
        "--curves",
        d / "c.csv",
        "--kalibr",
        d / "imu.yaml",
        "--imu-utils",
        d / "iu.yaml",
        "--plot",
        d / "figs",
    )
    assert rc == 0, err
    head, *body = out.splitlines()
    assert head.startswith("channel,unit,term,name,value,low,high") and len(body) == 30
    curves = (d / "c.csv").read_text().splitlines()
    assert curves[0].startswith("channel,unit,statistic,tau_s,dev") and len(curves) > 100
    assert {"oadev", "adev", "mdev", "hdev", "model_oadev"} <= {r.split(",")[2] for r in curves[1:]}
    for png in ("adev_accelerometer.png", "adev_gyroscope.png", "psd_accelerometer.png", "psd_gyroscope.png"):
        data = (d / "figs" / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
    doc = _json(run_cli, files["rows"], "--fs", "100", "--no-model")
    kal = (d / "imu.yaml").read_text()
    vals = dict(ln.split("#")[0].split(":") for ln in kal.splitlines() if ln and not ln.startswith("#"))
    n_gyro = max(doc["channels"][c]["terms"]["N"]["value"] for c in ("gx", "gy", "gz")) * math.pi / 180
    assert float(vals["gyroscope_noise_density"]) == pytest.approx(n_gyro, rel=1e-5)
    n_acc = max(doc["channels"][c]["terms"]["N"]["value"] for c in ("ax", "ay", "az"))
    assert float(vals["accelerometer_noise_density"]) == pytest.approx(n_acc, rel=1e-5)
    assert float(vals["update_rate"]) == 100 and "CONTINUOUS-TIME" in kal
    assert "accelerometer_random_walk" in vals and "gyroscope_random_walk" in vals
    iu = (d / "iu.yaml").read_text()
    assert iu.startswith("%YAML:1.0\n---\n") and "gyr_n:" in iu and "acc_w:" in iu and "x-axis:" in iu


def test_other_tau_grids_and_stdin(run_cli, files, monkeypatch) -> None:
    doc = _json(run_cli, files["rows"], "--fs", "100", "--taus", "decade", "--no-model", "--channels", "gx")
    assert [p["tau_s"] for p in doc["channels"]["gx"]["curve"]][:4] == [0.01, 0.02, 0.04, 0.1]
    import io
    import sys

    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(files["log"].read_bytes())))
    doc = _json(run_cli, "-", "--no-model", "--channels", "gy")
    assert doc["source"]["file"] == "<stdin>" and doc["source"]["kind"] == "device-log"


def test_model_fit_percent(run_cli, files) -> None:
    doc = _json(run_cli, files["rows"], "--fs", "100", "--channels", "gx,az")
    for c in ("gx", "az"):
        m = doc["channels"][c]["model"]
        fp = m["fit_percent"]
        assert {"adev_log10", "adev_log10_nrmse", "psd_log10", "signal"} <= set(fp)
        assert all(v < 100 for v in fp.values())
        assert fp["signal"] < 0  # the time series of two independent noises never match
        assert fp["adev_log10_nrmse"] < fp["adev_log10"]  # the thesis' form flatters
        assert m["params"]["white_sigma"] > 0 and len(m["curve"]) == len(doc["channels"][c]["curve"])


def test_files_larger_than_memory_are_streamed(run_cli, files) -> None:
    """With --memory 1 (MB) 40000 x 6 samples (1.9 MB in float64) do not fit: then
    octave ADEVs and PSD come from the streaming pass, equal to the in-memory ones."""
    big = files["dir"] / "big.txt"
    write_rows(big, thesis_like(40_000, 8))
    a = _json(run_cli, big, "--fs", "100", "--no-model")
    b = _json(run_cli, big, "--fs", "100", "--no-model", "--memory", "1")
    assert any("streamed" in s for s in b["notes"]) and not any("streamed" in s for s in a["notes"])
    assert "curves" in a["channels"]["gx"] and "mdev" not in b["channels"]["gx"].get("curves", {})
    da = [p["dev"] for p in a["channels"]["gx"]["curve"]]
    db = [p["dev"] for p in b["channels"]["gx"]["curve"]]
    assert da == db
    np.testing.assert_allclose(a["channels"]["gx"]["psd"]["psd"], b["channels"]["gx"]["psd"]["psd"], rtol=1e-9)
    assert a["channels"]["gx"]["terms"] == b["channels"]["gx"]["terms"]


def test_kalibr_needs_physical_units(run_cli, files) -> None:
    rc, out, err = run_cli(
        "analyze",
        files["rows"],
        "--fs",
        "100",
        "--profile",
        "counts",
        "--no-model",
        "--kalibr",
        files["dir"] / "k.yaml",
    )
    assert rc == 2 and err == (
        "imu-allan analyze: --kalibr needs channels in physical units: use the thesis profile or --scale\n"
    )


@pytest.mark.filterwarnings("error::UserWarning")  # matplotlib's "cannot be log-scaled" included
def test_a_constant_channel_is_analyzed_and_plotted_with_a_note(tmp_path: Path, run_cli) -> None:
    """A stuck gyro (a constant channel once broke the plot): the others are analyzed,
    the figure is written, and a note says why gx has no terms."""
    rng = np.random.default_rng(1)
    codes = np.clip(np.rint(rng.normal(500, 2, (20000, 7))), 0, 1023).astype(int)
    codes[:, 3] = 512
    rows = tmp_path / "stuck.txt"
    np.savetxt(rows, codes, fmt="%d", delimiter="\t")
    rc, out, err = run_cli("analyze", rows, "--fs", "100", "--no-model", "--json", "--plot", tmp_path / "figs")
    assert rc == 0, err
    doc = json.loads(out)
    assert any(n.startswith("gx is constant") for n in doc["notes"])
    assert all(p["dev"] is None for p in doc["channels"]["gx"]["curve"])
    assert doc["channels"]["gy"]["terms"]["N"] is not None
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == [
        "adev_accelerometer.png",
        "adev_gyroscope.png",
        "psd_accelerometer.png",
        "psd_gyroscope.png",
    ]


@pytest.mark.parametrize(
    "change,message",
    [
        (line("ok reset rate=250"), "the sample rate changes midway (100, then 250 Hz)"),
        (line("ok reset range=4"), "the accelerometer range changes midway (1.5, then 4 g)"),
    ],
)
def test_a_capture_whose_rate_or_range_changes_is_refused(change: bytes, message: str, tmp_path: Path, run_cli) -> None:
    rows = [raw_row([500 + i % 7, 1, 2, 3, 4, 5, 6]) for i in range(400)]
    cap = tmp_path / "cap.log"
    cap.write_bytes(
        line("ok status run=1 fs=100 mode=raw range=1.5") + b"".join(rows[:200]) + change + b"".join(rows[200:])
    )
    rc, out, err = run_cli("analyze", cap, "--fs", "100")
    assert rc == 2 and out == "" and err.count("\n") == 1 and message in err, err
    same = tmp_path / "same.log"  # a reply that restates the same rate is no change
    same.write_bytes(
        line("ok status run=1 fs=100 mode=raw range=1.5")
        + b"".join(rows[:200])
        + line("ok rate=100")
        + b"".join(rows[200:])
    )
    rc, _, err = run_cli("analyze", same, "--fs", "100", "--no-model")
    assert rc == 0, err


def _csv_with_time(path: Path, head: str, t: np.ndarray) -> Path:
    x = np.random.default_rng(3).normal(0.0, 0.01, (t.size, 3))
    with open(path, "w") as f:
        f.write(head + ",gx [rad/s],gy [rad/s],gz [rad/s]\n")
        for ti, row in zip(t, x):
            f.write(f"{ti}," + ",".join(f"{v:.6f}" for v in row) + "\n")
    return path


@pytest.mark.parametrize(
    "head,t",
    [
        ("%time", 1_700_000_000_000_000_000 + 5_000_000 * np.arange(3000)),  # rostopic echo -p: ns
        ("field.header.stamp", 1_700_000_000_000_000_000 + 5_000_000 * np.arange(3000)),
        ("time", 5_000_000 * np.arange(3000)),  # ns from 0
        ("timestamp", 5000 * np.arange(3000)),  # us from 0
        ("t", 5 * np.arange(3000)),  # ms from 0
        ("time", 1_700_000_000.0 + 0.005 * np.arange(3000)),  # epoch seconds
        ("time [us]", 5000 * np.arange(3000)),
        ("time_ms", 5 * np.arange(3000)),
    ],
)
def test_csv_time_column_in_any_unit(head: str, t: np.ndarray, tmp_path: Path, run_cli) -> None:
    """A CSV time column in integer ns, us, ms or s, told from its name or its magnitude: 200 Hz every time."""
    path = _csv_with_time(tmp_path / "imu.csv", head, t)
    rc, out, err = run_cli("analyze", path, "--no-model", "--json")
    assert rc == 0, err
    doc = json.loads(out)
    assert doc["source"]["fs_hz"] == pytest.approx(200.0, rel=1e-6)
    assert any(n.startswith("sample rate 200 Hz from the time column") for n in doc["notes"])


def test_csv_time_column_giving_an_absurd_rate_is_refused(tmp_path: Path, run_cli) -> None:
    path = _csv_with_time(tmp_path / "imu.csv", "time [s]", 1e-7 * np.arange(3000))  # 10 MHz
    rc, out, err = run_cli("analyze", path, "--no-model")
    assert rc == 2 and out == "" and err.count("\n") == 1
    assert "the time column gives 1e+07 Hz" in err and "outside 0.1 Hz .. 100000 Hz" in err


def test_clipped_codes_are_counted_and_the_terms_say_so(tmp_path: Path, run_cli) -> None:
    """Codes at 0 or 1023 (a clipped sensor misleads every term) counted per channel and warned about."""
    rng = np.random.default_rng(5)
    codes = np.clip(np.rint(rng.normal(500, 3, (20000, 7))), 0, 1023).astype(int)
    hits = rng.choice(20000, 37, replace=False)
    codes[hits, 4] = 1023  # gy clips 37 times
    codes[hits[:5], 0] = 0  # ax 5 times
    rows = tmp_path / "clip.txt"
    np.savetxt(rows, codes, fmt="%d", delimiter="\t")
    rc, out, err = run_cli("analyze", rows, "--fs", "100", "--no-model", "--json")
    assert rc == 0, err
    doc = json.loads(out)
    notes = [n for n in doc["notes"] if " clipped: " in n]
    assert [n.split(" clipped")[0] for n in notes] == ["ax", "gy"]
    assert "37 samples at code 0 or 1023 (0.185 % of 20000" in notes[1]
    gy = doc["channels"]["gy"]
    assert all("clipped channel (37 samples" in gy["term_notes"][k] for k, t in gy["terms"].items() if t)
    assert not any("clipped" in v for v in doc["channels"]["gx"]["term_notes"].values())


def test_a_capture_is_read_once(tmp_path: Path, run_cli, monkeypatch) -> None:
    """A capture was once opened to peek, decoded to count, decoded again and
    read a third time for the PSD; now its bytes are read in one pass."""
    import builtins

    rows = [raw_row([500 + (i * 7) % 13, 1, 2, 3 + i % 5, 4, 5, 6]) for i in range(3000)]
    cap = tmp_path / "cap.log"
    cap.write_bytes(line("ok mode=raw") + b"".join(rows))
    opened: list[str] = []
    real_open = builtins.open

    def counting_open(file, *a, **k):
        if str(file) == str(cap):
            opened.append(str(file))
        return real_open(file, *a, **k)

    monkeypatch.setattr(builtins, "open", counting_open)
    rc, out, err = run_cli("analyze", cap, "--fs", "100", "--json", "--memory", "1")
    assert rc == 0, err
    assert json.loads(out)["source"]["n"] == 3000 and opened == [str(cap)]
