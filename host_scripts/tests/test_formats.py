"""Every input format a user brings, written with the libraries users write them
with (rosbags for ROS 1 and ROS 2 bags, numpy for .npy/.npz, CSV text as EuRoC,
Kalibr and ``rostopic echo -p`` write it), analysed with nothing but the file
name (and --topic where a bag holds several IMU topics): the values read are
the values written, the rate is the stamps' rate, the units the format's."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from imu_allan.errors import InputError
from imu_allan.sources.detect import load

rosbags = pytest.importorskip("rosbags", reason="the rosbags package reads and writes the bags")
from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import StoragePlugin  # noqa: E402
from rosbags.rosbag2 import Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

N, FS = 3000, 200.0
T0_NS = 1_700_000_000_123_456_789  # an epoch stamp: more digits than a double holds
STEP_NS = 5_000_000
CH = ["ax", "ay", "az", "gx", "gy", "gz"]


@pytest.fixture(scope="module")
def imu() -> dict[str, Any]:
    """What the sensor gave: acc (m/s^2) and gyro (rad/s), (N, 3) each, and stamps."""
    rng = np.random.default_rng(11)
    acc = rng.normal(0.0, 0.02, (N, 3)) + [0.0, 0.0, 9.81]
    gyro = rng.normal(0.0, 0.001, (N, 3)) + [0.002, -0.001, 0.0005]
    stamps = T0_NS + STEP_NS * np.arange(N, dtype=np.int64)
    return {"acc": acc, "gyro": gyro, "stamps": stamps, "values": np.vstack([acc.T, gyro.T])}


def _imu_msg(ts: Any, i: int, d: dict[str, Any], frame: str) -> Any:
    T = ts.types
    ns = int(d["stamps"][i])
    head = {"stamp": T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9), "frame_id": frame}
    if "seq" in T["std_msgs/msg/Header"].__dataclass_fields__:  # ROS 1 headers count
        head["seq"] = i
    v3 = T["geometry_msgs/msg/Vector3"]
    g, a = d["gyro"][i], d["acc"][i]
    return T["sensor_msgs/msg/Imu"](
        header=T["std_msgs/msg/Header"](**head),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=np.zeros(9),
        angular_velocity=v3(x=g[0], y=g[1], z=g[2]),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=v3(x=a[0], y=a[1], z=a[2]),
        linear_acceleration_covariance=np.zeros(9),
    )


def write_ros1(path: Path, d: dict[str, Any], topics: dict[str, str], keep: Any = None, recorded: Any = None) -> Path:
    ts = get_typestore(Stores.ROS1_NOETIC)
    recorded = d["stamps"] + 40_000 if recorded is None else recorded
    with Writer1(path) as w:
        conns = {t: w.add_connection(t, "sensor_msgs/msg/Imu", typestore=ts) for t in topics}
        for i in range(N) if keep is None else keep:
            for t, frame in topics.items():
                w.write(
                    conns[t],
                    int(recorded[i]),
                    ts.serialize_ros1(_imu_msg(ts, i, d, frame), conns[t].msgtype),
                )
    return path


def write_ros2(path: Path, d: dict[str, Any], storage: Any, frame: str = "imu_link") -> Path:
    ts = get_typestore(Stores.ROS2_HUMBLE)
    with Writer2(path, version=9, storage_plugin=storage) as w:
        conn = w.add_connection("/imu", "sensor_msgs/msg/Imu", typestore=ts)
        other = w.add_connection("/rosout_count", "std_msgs/msg/Int32", typestore=ts)
        for i in range(N):
            w.write(conn, int(d["stamps"][i]) + 40_000, ts.serialize_cdr(_imu_msg(ts, i, d, frame), conn.msgtype))
        w.write(other, int(d["stamps"][0]), ts.serialize_cdr(ts.types["std_msgs/msg/Int32"](data=1), other.msgtype))
    return path


def _rows(d: dict[str, Any]) -> list[tuple[int, list[float], list[float]]]:
    """(stamp ns, gyro, acc) per sample, as Python numbers (their repr is what a CSV holds)."""
    return [
        (int(d["stamps"][i]), [float(v) for v in d["gyro"][i]], [float(v) for v in d["acc"][i]])
        for i in range(len(d["stamps"]))
    ]


def write_euroc(path: Path, d: dict[str, Any]) -> Path:
    head = "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
    head += "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n"
    body = "".join(f"{t},{','.join(map(repr, g))},{','.join(map(repr, a))}\n" for t, g, a in _rows(d))
    path.write_text(head + body)
    return path


def write_kalibr(path: Path, d: dict[str, Any], extra: bool = False) -> Path:
    head = "timestamp,omega_x,omega_y,omega_z,alpha_x,alpha_y,alpha_z" + (",temperature" if extra else "") + "\n"
    tail = ",31.5" if extra else ""
    body = "".join(f"{t},{','.join(map(repr, g))},{','.join(map(repr, a))}{tail}\n" for t, g, a in _rows(d))
    path.write_text(head + body)
    return path


def write_rostopic_echo(path: Path, d: dict[str, Any]) -> Path:
    """``rostopic echo -b x.bag -p /imu``: %time (receive), the header, every field flattened."""
    cols = ["%time", "field.header.seq", "field.header.stamp", "field.header.frame_id"]
    cols += [f"field.orientation.{a}" for a in "xyzw"] + [f"field.orientation_covariance{k}" for k in range(9)]
    cols += [f"field.angular_velocity.{a}" for a in "xyz"] + [f"field.angular_velocity_covariance{k}" for k in range(9)]
    cols += [f"field.linear_acceleration.{a}" for a in "xyz"]
    cols += [f"field.linear_acceleration_covariance{k}" for k in range(9)]
    lines = [",".join(cols)]
    for i, (t, g, a) in enumerate(_rows(d)):
        received = t + 700_000 + (i % 7) * 90_000  # receive times jitter; the header stamps do not
        cov = ["0.0"] * 9
        lines.append(
            ",".join(
                [str(received), str(i), str(t), "imu", "0.0", "0.0", "0.0", "1.0", *cov]
                + [repr(v) for v in g]
                + cov
                + [repr(v) for v in a]
                + cov
            )
        )
    path.write_text("\n".join(lines) + "\n")
    return path


def write_npy(path: Path, d: dict[str, Any]) -> Path:
    t = (d["stamps"] - d["stamps"][0]) / 1e9
    np.save(path, np.column_stack([t, d["acc"], d["gyro"]]))
    return path


def write_npz(path: Path, d: dict[str, Any]) -> Path:
    np.savez(path, t=(d["stamps"] - d["stamps"][0]) / 1e9, acc=d["acc"], gyro=d["gyro"], frame=np.zeros(2))
    return path


def _analyze(run_cli: Any, *argv: Any) -> dict[str, Any]:
    rc, out, err = run_cli("analyze", *argv, "--json", "--no-model")
    assert rc == 0, err
    return json.loads(out)


def _first_point(x: np.ndarray) -> float:
    """Overlapping Allan deviation at tau = 1/fs: sqrt(mean(diff^2) / 2) (IEEE 952)."""
    return math.sqrt(0.5 * float(np.mean(np.diff(x) ** 2)))


FORMATS = {
    "ros1_bag": lambda p, d: write_ros1(p / "run.bag", d, {"/imu": "imu_link"}),
    "ros2_sqlite_folder": lambda p, d: write_ros2(p / "run", d, StoragePlugin.SQLITE3),
    "ros2_db3_file": lambda p, d: write_ros2(p / "run", d, StoragePlugin.SQLITE3) / "run.db3",
    "ros2_mcap_file": lambda p, d: write_ros2(p / "run", d, StoragePlugin.MCAP) / "run.mcap",
    "euroc_csv": lambda p, d: write_euroc(p / "data.csv", d),
    "kalibr_csv": lambda p, d: write_kalibr(p / "imu0.csv", d),
    "rostopic_echo_csv": lambda p, d: write_rostopic_echo(p / "imu.csv", d),
    "npy": lambda p, d: write_npy(p / "imu.npy", d),
    "npz": lambda p, d: write_npz(p / "imu.npz", d),
}


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_each_format_reads_back_what_was_written(fmt: str, imu: dict[str, Any], tmp_path: Path) -> None:
    path = FORMATS[fmt](tmp_path, imu)
    s = load(str(path)).samples
    assert s is not None and s.channels == CH
    assert np.array_equal(np.concatenate(list(s.open_blocks()), axis=1), imu["values"])
    assert s.fs == pytest.approx(FS, rel=1e-9)
    assert s.units == {ch: ("rad/s" if ch[0] == "g" else "m/s^2") for ch in CH}
    assert s.time.found["rows"] == N and s.time.found["gaps"] == 0


@pytest.mark.parametrize("fmt", ["ros1_bag", "ros2_sqlite_folder", "euroc_csv", "rostopic_echo_csv", "npy"])
def test_a_new_users_file_is_analysed_with_no_option(fmt: str, imu: dict[str, Any], tmp_path: Path, run_cli) -> None:
    """No --fs, no --scale: the stamps give the rate, the format the units
    (gyros reported in deg/s, accelerometers in m/s^2)."""
    doc = _analyze(run_cli, FORMATS[fmt](tmp_path, imu))
    assert doc["source"]["fs_hz"] == pytest.approx(FS, rel=1e-9) and doc["source"]["n"] == N
    for i, ch in enumerate(CH):
        c = doc["channels"][ch]
        to_unit = 180.0 / math.pi if ch[0] == "g" else 1.0
        assert c["unit"] == ("deg/s" if ch[0] == "g" else "m/s^2")
        first = c["curve"][0]
        assert first["m"] == 1 and first["dev"] == pytest.approx(_first_point(imu["values"][i]) * to_unit, rel=1e-9)
    assert not any("ADC counts" in n for n in doc["notes"])  # every channel has its unit


def test_a_bag_with_two_imu_topics_asks_for_one(imu: dict[str, Any], tmp_path: Path, run_cli) -> None:
    other = dict(imu, gyro=imu["gyro"] * 3.0)
    bag = tmp_path / "two.bag"
    write_ros1(bag, imu, {"/imu0": "a", "/imu1": "a_much_longer_frame"})
    rc, out, err = run_cli("analyze", bag)
    assert rc == 2 and out == "" and err.count("\n") == 1
    assert "--topic" in err and "/imu0" in err and "/imu1" in err
    doc = _analyze(run_cli, bag, "--topic", "/imu1")
    gx = doc["channels"]["gx"]["curve"][0]["dev"]
    assert gx == pytest.approx(_first_point(imu["gyro"][:, 0]) * 180.0 / math.pi, rel=1e-9)
    assert any("/imu0" in n and "not read" in n for n in doc["notes"])
    rc, out, err = run_cli("analyze", bag, "--topic", "/cam")
    assert rc == 2 and "/cam" in err and "/imu0, /imu1" in err
    del other


def test_stamps_show_the_gaps_of_a_bag(imu: dict[str, Any], tmp_path: Path, run_cli) -> None:
    """Messages 1000..1039 and 2000..2004 never recorded: two gaps, 45 samples
    missing, the longest 41 periods; said next to the numbers."""
    keep = [i for i in range(N) if not (1000 <= i < 1040 or 2000 <= i < 2005)]
    bag = write_ros1(tmp_path / "gaps.bag", imu, {"/imu": "imu"}, keep=keep)
    s = load(str(bag)).samples
    list(s.open_blocks())
    found = s.time.found
    assert (found["gaps"], found["missing_samples"], found["rows"]) == (2, 45, len(keep))
    assert found["longest_gap_s"] == pytest.approx(41 * STEP_NS / 1e9)
    doc = _analyze(run_cli, bag)
    assert any("2 gaps" in n and "45 samples missing" in n for n in doc["notes"])
    assert not any("over the whole file" in n for n in doc["notes"])  # missing samples are no change of rate


def test_no_column_is_dropped_silently(imu: dict[str, Any], tmp_path: Path, run_cli) -> None:
    doc = _analyze(run_cli, write_kalibr(tmp_path / "k.csv", imu, extra=True))
    assert list(doc["channels"]) == CH  # alpha_* are Kalibr's accelerometer columns
    assert any("not used: temperature" in n for n in doc["notes"])
    doc = _analyze(run_cli, write_rostopic_echo(tmp_path / "e.csv", imu))
    said = next(n for n in doc["notes"] if "not used" in n)
    for col in ("%time", "field.header.seq", "field.orientation*", "field.linear_acceleration_covariance* (9)"):
        assert col in said


def test_options_that_contradict_the_file_are_errors(imu: dict[str, Any], tmp_path: Path, run_cli) -> None:
    p = tmp_path / "gyro.csv"
    p.write_text("t,gx [rad/s],gy [rad/s],gz [rad/s]\n" + "".join(f"{i / FS!r},0.1,0.2,{i % 5}\n" for i in range(N)))
    rc, out, err = run_cli("analyze", p, "--scale", "ax=0.0039g")
    assert rc == 2 and out == "" and err.count("\n") == 1 and "gyro.csv" in err and "no channel ax" in err
    rc, out, err = run_cli("analyze", p, "--fs", "100")
    assert rc == 2 and err.count("\n") == 1 and "gyro.csv" in err and "--fs 100 contradicts" in err
    assert _analyze(run_cli, p, "--fs", "200")["source"]["fs_hz"] == 200


def test_one_column_named_by_its_unit(tmp_path: Path, run_cli) -> None:
    x = np.random.default_rng(5).normal(0.0, 0.3, 2000)  # deg/s
    p = tmp_path / "rate.txt"
    p.write_text("gz [deg/s]\n" + "".join(f"{float(v)!r}\n" for v in x))
    doc = _analyze(run_cli, p, "--fs", "100")
    assert list(doc["channels"]) == ["gz"] and doc["channels"]["gz"]["unit"] == "deg/s"
    assert doc["channels"]["gz"]["curve"][0]["dev"] == pytest.approx(_first_point(x), rel=1e-9)


def test_integer_npy_is_adc_codes_like_a_rows_file(tmp_path: Path) -> None:
    codes = np.random.default_rng(2).integers(0, 1024, (500, 7)).astype(np.int16)
    np.save(tmp_path / "codes.npy", codes)
    s = load(str(tmp_path / "codes.npy")).samples
    assert s.integer and np.array_equal(np.concatenate(list(s.open_blocks()), axis=1), codes[:, :6].T)
    assert np.array_equal(np.concatenate(list(s.open_temperature())), codes[:, 6])
    assert any("(temp) not used" in n for n in s.notes)  # no column dropped without a word
    np.save(tmp_path / "bad.npy", codes * 4)
    with pytest.raises(InputError, match="not 10-bit ADC codes"):
        list(load(str(tmp_path / "bad.npy")).samples.open_blocks())


def test_small_blocks_read_the_same_values_and_gaps(imu: dict[str, Any], tmp_path: Path, monkeypatch) -> None:
    """A CSV read 4 KB at a time (every block boundary inside the data, one
    across a gap) gives the values of one read and the gap once."""
    from imu_allan.sources import table

    keep = np.r_[0:1500, 1507:N]  # 7 samples never written
    d = dict(imu, stamps=imu["stamps"][keep], gyro=imu["gyro"][keep], acc=imu["acc"][keep])
    lines = [f"{t},{','.join(map(repr, g))},{','.join(map(repr, a))}" for t, g, a in _rows(d)]
    p = tmp_path / "imu0.csv"
    p.write_text("timestamp,omega_x,omega_y,omega_z,alpha_x,alpha_y,alpha_z\n" + "\n".join(lines) + "\n")
    whole = np.concatenate(list(load(str(p)).samples.open_blocks()), axis=1)
    monkeypatch.setattr(table, "BLOCK_BYTES", 4096)
    s = load(str(p)).samples
    blocks = list(s.open_blocks())
    assert len(blocks) > 50
    assert np.array_equal(np.concatenate(blocks, axis=1), whole)
    assert np.array_equal(whole, np.vstack([d["acc"].T, d["gyro"].T]))
    assert (s.time.found["gaps"], s.time.found["missing_samples"]) == (1, 7)


@pytest.mark.parametrize(
    "text",
    [
        b"1\t2\t3\t4\t5\t6\t7\n8\t9\t10\t11\t12\t13\t14\n",
        b"1 2 3 4 5 6 7\n  8\t9 10  11 12 13 14  \n",
        b"1\t2\t3\t4\t5\t6\t7\n\n8\t9\t10\t11\t12\t13\t14",
        b"1\t2\t3\t4\t5\t6\t7\t\n",
        b"1\t2\t3\t4\t5\t6\n",
        b"1\t2\t3\t4\t5\t6\t7\t8\n",
        b"1\t2\t3\t4\t5\t6\t1024\n",
        b"1\t2\t3\t4\t5\t6\t+7\n",
        b"1\t2\t3\t4\t5\t6\t7.0\n",
        b"0001\t2\t3\t4\t5\t6\t7\n",
    ],
)
def test_rows_compiled_reader_agrees_with_the_exact_one(text: bytes) -> None:
    """pandas' reader takes a block only when it reads it exactly as the numpy
    reader of the format does; anything else gets the numpy reader's answer."""
    from imu_allan.sources.rows import parse_block, parse_exact

    try:
        want: Any = parse_exact(text, "f", 1, 7)
    except InputError as exc:
        want = str(exc)
    try:
        got: Any = parse_block(text, "f", 1, 7)
    except InputError as exc:
        got = str(exc)
    if isinstance(want, str):
        assert got == want
    else:
        assert got.dtype == want.dtype and np.array_equal(got, want)


def test_a_bag_whose_driver_left_the_stamps_zero_uses_the_recorded_times(imu: dict[str, Any], tmp_path: Path) -> None:
    zero = dict(imu, stamps=np.zeros(N, dtype=np.int64))
    recorded = T0_NS + 2 * STEP_NS * np.arange(N, dtype=np.int64)  # 100 Hz as the bag saw them
    s = load(str(write_ros1(tmp_path / "z.bag", zero, {"/imu": "imu"}, recorded=recorded))).samples
    assert s.fs == pytest.approx(FS / 2, rel=1e-9)
    assert any("do not increase" in n and "bag's times" in n for n in s.notes)
    assert np.array_equal(np.concatenate(list(s.open_blocks()), axis=1), imu["values"])


def test_an_array_is_analysed_in_text_as_well_as_json(tmp_path: Path) -> None:
    """analyze's text names every kind of source (arrays and bags were a
    KeyError without --json)."""
    path = tmp_path / "still.npy"
    np.save(path, np.random.default_rng(4).normal(size=(20000, 6)))
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    for extra in ("--brief", "--no-model"):
        out = subprocess.run(  # a short name: a long path wraps across lines
            [sys.executable, "-m", "imu_allan.cli", "analyze", path.name, "--fs", "100", extra],
            capture_output=True,
            text=True,
            cwd=tmp_path,
            env=env,
        )
        assert out.returncode == 0, out.stderr[-500:]
    assert " ".join(out.stdout.split()).startswith("still.npy: NumPy array, 20000 samples at 100 Hz")


@pytest.mark.parametrize("damage", ["cut", "flipped"])
def test_a_damaged_npz_is_one_line_naming_it(tmp_path: Path, run_cli, damage: str) -> None:
    """A .npz cut short (a copy stopped midway) or with one byte changed (its
    CRC no longer holds): one line naming the file, no traceback."""
    rng = np.random.default_rng(8)
    p = tmp_path / "imu.npz"
    np.savez(p, t=np.arange(3000) / 100.0, acc=rng.normal(size=(3000, 3)), gyro=rng.normal(size=(3000, 3)))
    data = bytearray(p.read_bytes())
    if damage == "cut":
        data = data[: len(data) // 2]
    else:
        data[len(data) // 3] ^= 0xFF  # inside the first member's bytes
    p.write_bytes(bytes(data))
    rc, out, err = run_cli("analyze", p)
    assert rc == 2 and out == "" and err.count("\n") == 1 and "imu.npz" in err and "Traceback" not in err


HEADERS = {
    # PX4's sensor_combined through ulog2csv: vectors as name[0..2], the unit in the name, time in us
    "px4": (
        "timestamp,gyro_rad[0],gyro_rad[1],gyro_rad[2],gyro_integral_dt,accelerometer_m_s2[0],"
        "accelerometer_m_s2[1],accelerometer_m_s2[2]",
        lambda k, g, a: f"{1_000_000 + k * 5000},{g[0]!r},{g[1]!r},{g[2]!r},5000,{a[0]!r},{a[1]!r},{a[2]!r}",
        {"gx": math.degrees(1.0), "ax": 1.0},
    ),
    # phyphox and spreadsheets quote the names; a time column named with its unit
    "quoted": (
        '"t_ms";"Gyroscope x (rad/s)";"Gyroscope y (rad/s)";"Gyroscope z (rad/s)"',
        lambda k, g, a: f"{k * 5.0!r};{g[0]!r};{g[1]!r};{g[2]!r}",
        {"gx": math.degrees(1.0)},
    ),
    # ST's MEMS drivers give rates in mdps
    "mdps": (
        "time_us\tgx [mdps]\tgy [mdps]\tgz [mdps]",
        lambda k, g, a: f"{k * 5000}\t{g[0]!r}\t{g[1]!r}\t{g[2]!r}",
        {"gx": 1e-3},
    ),
}


@pytest.mark.parametrize("layout", sorted(HEADERS))
def test_headers_other_tools_write(layout: str, tmp_path: Path, run_cli) -> None:
    """Each channel found by its name, in the unit its name or bracket says,
    the rate from a time column named with its unit or told from its step (200 Hz),
    with no option: the first Allan point is the one computed here from the values
    written, times the unit's factor to deg/s or m/s^2."""
    header, row, factor = HEADERS[layout]
    rng = np.random.default_rng(4)
    g, a = rng.normal(0.0, 0.01, (3000, 3)), rng.normal(0.0, 0.05, (3000, 3))
    p = tmp_path / f"{layout}.csv"
    p.write_text(header + "\n" + "".join(row(k, g[k].tolist(), a[k].tolist()) + "\n" for k in range(3000)))
    doc = _analyze(run_cli, p)
    assert doc["source"]["fs_hz"] == pytest.approx(200.0, rel=1e-9)
    for ch, f in factor.items():
        x = (g if ch[0] == "g" else a)[:, "xyz".index(ch[1])]
        assert doc["channels"][ch]["curve"][0]["dev"] == pytest.approx(_first_point(x) * f, rel=1e-9)
    # every channel the file has carries its unit: none is said to stay in ADC counts
    assert not [n for n in doc["notes"] if "ADC counts" in n]


def test_stamps_taken_on_arrival_come_bunched_and_the_span_gives_the_rate(tmp_path: Path, run_cli) -> None:
    """A driver that stamps samples when they reach the computer: 50 Hz samples
    arrive in pairs (0.1 ms apart) every 40 ms, each pair a few ms late. The
    median step (40 ms) is no period: the rows over their span are. Samples
    never sent (30 of them, late in the file) are still one gap, and the
    bunching itself is none."""
    fs, n, cut = 50.0, 12000, range(10000, 10030)
    rng = np.random.default_rng(7)
    k = np.arange(n)
    t = (k // 2) * 2 / fs + np.repeat(rng.uniform(0.0, 4e-3, n // 2), 2) + (k % 2) * 1e-4
    x = rng.normal(0.0, 0.3, n)
    keep = np.array([i for i in k if i not in cut])
    p = tmp_path / "arrivals.csv"
    p.write_text("t,gz [deg/s]\n" + "".join(f"{float(t[i])!r},{float(x[i])!r}\n" for i in keep))
    doc = _analyze(run_cli, p)
    assert doc["source"]["fs_hz"] == pytest.approx(fs, rel=2e-3)
    assert any("bunched" in note for note in doc["notes"])
    gaps = [note for note in doc["notes"] if "gap" in note]
    assert len(gaps) == 1 and gaps[0].count("1 gap ") == 1
    # a pair's arrival stands for two samples: the count is known to one sample
    assert "about 30 samples missing" in gaps[0] or "about 31 samples missing" in gaps[0]
    assert not any("over the whole file" in note for note in doc["notes"])  # the gap is no change of rate


def test_stamps_rounded_coarser_than_the_period_are_no_gaps(tmp_path: Path, run_cli) -> None:
    """A writer that keeps two decimals of the time (phyphox-like exports, a logger's %.2f)
    from 100 s on: at 200 Hz each 0.01 s stamp step stands for two samples, and every other
    step is 0. Every sample is there (the rows over the span give the rate): no gaps, no
    samples missing, no other rate over the whole file; a real gap in such a file still is one."""
    fs, n = 200.0, 60000
    rng = np.random.default_rng(3)
    t = np.arange(n) / fs
    x = rng.normal(0.0, 0.3, n)
    stamp = [repr(float(v)) if v < 100 else f"{v:.2f}" for v in t]
    p = tmp_path / "rounded.csv"
    p.write_text("time [s],gz [deg/s]\n" + "".join(f"{s},{float(v)!r}\n" for s, v in zip(stamp, x)))
    doc = _analyze(run_cli, p)
    assert doc["source"]["fs_hz"] == pytest.approx(fs, rel=1e-6)
    notes = [note for note in doc["notes"] if note.startswith("the time column")]
    assert len(notes) == 1 and "coarser than the sample period" in notes[0], notes
    assert "samples missing" not in notes[0] and "over the whole file" not in notes[0]
    cut = np.r_[0:30000, 30050:n]  # 50 samples never written, in the rounded part
    q = tmp_path / "rounded_gap.csv"
    q.write_text("time [s],gz [deg/s]\n" + "".join(f"{stamp[i]},{float(x[i])!r}\n" for i in cut))
    gap = [note for note in _analyze(run_cli, q)["notes"] if note.startswith("the time column")]
    assert len(gap) == 1 and "samples missing" in gap[0], gap
