"""A driver's own message that holds a sensor_msgs/Imu field (a VectorNav
driver's {header, imu, mag_field, ...}): read through that field, from bags
written with rosbags' own writers and the bag's own message definitions."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("rosbags")
from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: E402

from imu_allan.errors import InputError  # noqa: E402
from imu_allan.sources.detect import load  # noqa: E402

CARRIER = "drv_msgs/msg/ImuPlus"
CARRIER_DEF = "std_msgs/Header header\nsensor_msgs/Imu imu\nfloat64 temperature\n"
N, STEP_NS, T0_NS = 400, 10_000_000, 1_678_936_390_997_898_340


def _store(ros1: bool) -> Any:
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    ts.register(get_types_from_msg(CARRIER_DEF, CARRIER))
    return ts


def _header(T: Any, ros1: bool, sec: int, nsec: int, i: int) -> Any:
    head: dict[str, Any] = {"stamp": T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), "frame_id": "vn"}
    if ros1:
        head["seq"] = i
    return T["std_msgs/msg/Header"](**head)


def _message(T: Any, ros1: bool, i: int, vals: np.ndarray, broken_inner: bool) -> Any:
    ns = T0_NS + i * STEP_NS
    sec, nsec = ns // 10**9, ns % 10**9
    v3 = T["geometry_msgs/msg/Vector3"]
    imu = T[
        "sensor_msgs/msg/Imu"
    ](
        header=_header(T, ros1, sec, sec if broken_inner else nsec, i),  # a driver that put sec in nanosec
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=np.zeros(9),
        angular_velocity=v3(*vals[3:, i]),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=v3(*vals[:3, i]),
        linear_acceleration_covariance=np.zeros(9),
    )
    return T[CARRIER](header=_header(T, ros1, sec, nsec, i), imu=imu, temperature=21.5)


def _write(path: Path, ros1: bool, vals: np.ndarray, broken_inner: bool, topics: tuple[str, ...] = ("/vn",)) -> Path:
    ts = _store(ros1)
    w: Any = Writer1(path) if ros1 else Writer2(path, version=9)
    with w:
        conns = [w.add_connection(t, CARRIER, typestore=ts) for t in topics]
        log = w.add_connection("/rosout_count", "std_msgs/msg/Int32", typestore=ts)
        for i in range(N):
            m = _message(ts.types, ros1, i, vals, broken_inner)
            for c in conns:
                w.write(c, T0_NS + i * STEP_NS + 40_000, (ts.serialize_ros1 if ros1 else ts.serialize_cdr)(m, CARRIER))
        one = ts.types["std_msgs/msg/Int32"](data=1)
        w.write(log, T0_NS, (ts.serialize_ros1 if ros1 else ts.serialize_cdr)(one, log.msgtype))
    return path


@pytest.mark.parametrize("ros1", [True, False], ids=["ros1", "ros2"])
@pytest.mark.parametrize("broken_inner", [False, True], ids=["field-stamps", "own-header-stamps"])
def test_a_topic_holding_an_imu_field_is_read_through_it(ros1: bool, broken_inner: bool, tmp_path: Path) -> None:
    vals = np.random.default_rng(5).normal(size=(6, N))
    path = _write(tmp_path / ("v.bag" if ros1 else "v"), ros1, vals, broken_inner)
    src = load(str(path)).samples
    got = np.concatenate(list(src.open_blocks()), axis=1)
    assert np.array_equal(got, vals)
    assert src.fs == pytest.approx(1e9 / STEP_NS, rel=1e-9)
    notes = " ".join(src.notes)
    assert f"topic /vn ({CARRIER}): its field imu (sensor_msgs/Imu)" in notes
    assert "from the header stamps of /vn" in notes  # not the times the bag recorded them
    assert ("imu.header are not times" in notes) == broken_inner


def test_several_topics_holding_an_imu_field_ask_for_one(tmp_path: Path) -> None:
    vals = np.random.default_rng(6).normal(size=(6, N))
    path = _write(tmp_path / "two.bag", True, vals, False, topics=("/vn_a", "/vn_b"))
    with pytest.raises(InputError, match=r"2 topics hold a sensor_msgs/Imu: choose one with --topic \(/vn_a, /vn_b\)"):
        load(str(path))
    got = np.concatenate(list(load(str(path), topic="/vn_b").samples.open_blocks()), axis=1)
    assert np.array_equal(got, vals)
    with pytest.raises(InputError, match=r"--topic /rosout_count: no sensor_msgs/Imu messages on it .*/vn_a, /vn_b"):
        load(str(path), topic="/rosout_count")
