"""ROS 1 and ROS 2 bags: the sensor_msgs/Imu messages of one topic, block by block.

Read with the ``rosbags`` library (pure Python, no ROS install): a ROS 1
``.bag``, a ROS 2 bag folder (metadata.yaml beside its storage), or its
``.db3`` (sqlite3) or ``.mcap`` file alone. ``angular_velocity`` (rad/s) and
``linear_acceleration`` (m/s^2) become gx gy gz and ax ay az, in the units the
message defines (REP 103), so no --scale is needed; the header stamps give
the sample rate and the gaps (timing.py), or, when a driver leaves them zero,
the times the bag recorded the messages.

Messages are decoded as arrays, a block of them at a time: the fields of
sensor_msgs/Imu lie at offsets that only the frame_id's length moves (ROS 1
packs them, CDR aligns the doubles to 8 bytes). The first message of a
topic is decoded by rosbags too, and a disagreement (a message definition
not the standard one) falls back to rosbags for every message.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterator, Optional

import numpy as np

from ..channels import CHANNELS
from ..errors import InputError
from .timing import rate_from_time

IMU_TYPE = "sensor_msgs/msg/Imu"
BLOCK_MESSAGES = 1 << 16
"""Messages decoded at a time: 6 values each, about 3 MB a block."""
SNIFF_MESSAGES = 2048
"""Messages whose stamps give the sample rate before the pass."""
_GYRO_AT, _ACC_AT, _TAIL = 104, 200, 296  # after the frame_id: 4+9 doubles, 3+9, 3+9
UNITS = {ch: ("rad/s" if ch[0] == "g" else "m/s^2") for ch in CHANNELS}


def _reader(path: str, name: str) -> Any:
    try:
        from rosbags.highlevel import AnyReader
    except ImportError:
        raise InputError(f"'{name}': reading ROS bags needs the rosbags package (pip install rosbags)") from None
    try:
        r = AnyReader([Path(path)])
        r.open()
    except Exception as exc:  # the library's own errors: a damaged or unknown bag
        raise InputError(f"'{name}': not a readable ROS bag ({type(exc).__name__}: {exc})") from None
    return r


def _pick(name: str, reader: Any, topic: Optional[str]) -> list[Any]:
    imu = sorted({c.topic for c in reader.connections if c.msgtype == IMU_TYPE})
    if not imu:
        seen = ", ".join(sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections})) or "none"
        raise InputError(f"'{name}': no sensor_msgs/Imu topic in the bag (topics: {seen})")
    if topic is None and len(imu) > 1:
        raise InputError(f"'{name}': {len(imu)} IMU topics: choose one with --topic ({', '.join(imu)})")
    chosen = topic if topic is not None else imu[0]
    if chosen not in imu:
        raise InputError(
            f"'{name}': --topic {chosen}: no sensor_msgs/Imu messages on it (IMU topics: {', '.join(imu)})"
        )
    return [c for c in reader.connections if c.topic == chosen and c.msgtype == IMU_TYPE]


def bag_source(path: str, name: str, topic: Optional[str]) -> Any:
    """The SampleSource of the IMU topic of the bag at ``path``."""
    from .source import SampleSource

    reader = _reader(path, name)
    try:
        conns = _pick(name, reader, topic)
        chosen = conns[0].topic
        count = sum(c.msgcount for c in conns)
        others = sorted({c.topic for c in reader.connections} - {chosen})
        first = next(_blocks(reader, conns, SNIFF_MESSAGES), None)
    finally:
        reader.close()
    if first is None or first[0].shape[1] < 3:
        raise InputError(
            f"'{name}': topic {chosen} holds {0 if first is None else first[0].shape[1]} messages: too few"
        )
    vals, stamps, recorded = first
    use_stamps = bool(np.all(np.diff(stamps) > 0))
    t = stamps if use_stamps else recorded
    t0 = int(t[0])
    what = f"the header stamps of {chosen}" if use_stamps else f"the times the bag recorded {chosen}"
    check = rate_from_time(name, (t - t0).astype(np.float64), 1e-9, what)
    src = SampleSource(
        "rosbag", name, list(CHANNELS), lambda: iter(()), False, fs=check.fs, n_hint=count, units=dict(UNITS)
    )
    src.time, src.topic = check, chosen
    src.notes.append(check.note)
    if not use_stamps:
        src.notes.append(f"the header stamps of {chosen} do not increase (left zero?): the bag's times used")
    src.notes.append(
        f"topic {chosen} (sensor_msgs/Imu): angular_velocity and linear_acceleration read in rad/s "
        "and m/s^2 (the message's units); orientation and the three covariances not used"
        + (f"; topics not read: {', '.join(others)}" if others else "")
    )

    def blocks() -> Iterator[np.ndarray]:
        r = _reader(path, name)
        check.start()
        done = 0
        try:
            for vals, stamps, recorded in _blocks(r, _pick(name, r, chosen), BLOCK_MESSAGES):
                check.feed(((stamps if use_stamps else recorded) - t0).astype(np.float64))
                bad = ~np.isfinite(vals).all(axis=0)
                if bad.any():
                    k = done + int(np.argmax(bad))
                    raise InputError(f"'{name}': topic {chosen}, message {k + 1}: a value is not a finite number")
                done += vals.shape[1]
                yield vals
        finally:
            r.close()
        check.finish(src.notes)

    src.open_blocks = blocks
    return src


def _blocks(reader: Any, conns: list[Any], size: int) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(6, k) values ax ay az gx gy gz, (k,) header stamps in ns, (k,) bag times in ns."""
    fast: Optional[bool] = None
    raws: list[bytes] = []
    times: list[int] = []
    ros1 = False
    for conn, t, raw in reader.messages(connections=conns):
        if fast is None:
            ros1 = _is_ros1(conn)
            fast = _agrees(reader, conn, raw, ros1)
        raws.append(raw)
        times.append(t)
        if len(raws) == size:
            yield _decode(reader, conns[0], raws, times, ros1, bool(fast))
            raws, times = [], []
    if raws:
        yield _decode(reader, conns[0], raws, times, ros1, bool(fast))


def _is_ros1(conn: Any) -> bool:
    return type(conn.ext).__name__ == "ConnectionExtRosbag1"


def _agrees(reader: Any, conn: Any, raw: bytes, ros1: bool) -> bool:
    """The array decoding gives what rosbags gives on this message."""
    try:
        vals, stamp = _fast([raw], ros1)
    except ValueError:
        return False
    m = reader.deserialize(raw, conn.msgtype)
    want = _values(m)
    return bool(np.array_equal(vals[:, 0], want, equal_nan=True)) and int(stamp[0]) == _stamp(m)


def _values(m: Any) -> np.ndarray:
    a, w = m.linear_acceleration, m.angular_velocity
    return np.array([a.x, a.y, a.z, w.x, w.y, w.z], dtype=np.float64)


def _stamp(m: Any) -> int:
    s = m.header.stamp
    return int(s.sec) * 1_000_000_000 + int(s.nanosec)


def _decode(
    reader: Any, conn: Any, raws: list[bytes], times: list[int], ros1: bool, fast: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    recorded = np.asarray(times, dtype=np.int64)
    if fast:
        try:
            vals, stamps = _fast(raws, ros1)
            return vals, stamps, recorded
        except ValueError:
            pass  # a message of another length: every field through rosbags
    msgs = [reader.deserialize(r, conn.msgtype) for r in raws]
    vals = np.array([_values(m) for m in msgs], dtype=np.float64).T
    stamps = np.array([_stamp(m) for m in msgs], dtype=np.int64)
    return np.ascontiguousarray(vals), stamps, recorded


def _gather(buf: np.ndarray, at: np.ndarray, nbytes: int, dtype: str) -> np.ndarray:
    return buf[at[:, None] + np.arange(nbytes)].view(dtype)


def _fast(raws: list[bytes], ros1: bool) -> tuple[np.ndarray, np.ndarray]:
    """Values (6, k) and stamps (k,) ns of standard sensor_msgs/Imu messages,
    little-endian (ValueError when a message is not laid out so)."""
    lens = np.fromiter(map(len, raws), dtype=np.int64, count=len(raws))
    buf = np.frombuffer(b"".join(raws), dtype=np.uint8)
    start = np.cumsum(lens) - lens
    if np.any(lens < 24):
        raise ValueError("short message")
    if ros1:  # seq, secs, nsecs, frame_id (length, bytes), then packed doubles
        sec = _gather(buf, start + 4, 4, "<u4")[:, 0].astype(np.int64)
        nsec = _gather(buf, start + 8, 4, "<u4")[:, 0].astype(np.int64)
        flen = _gather(buf, start + 12, 4, "<u4")[:, 0].astype(np.int64)
        base = start + 16 + flen
    else:  # CDR: 4-byte encapsulation (little-endian: 00 01), sec, nanosec, string, doubles aligned to 8
        if np.any(buf[start + 1] != 1) or np.any(buf[start] != 0):
            raise ValueError("not little-endian CDR")
        sec = _gather(buf, start + 4, 4, "<i4")[:, 0].astype(np.int64)
        nsec = _gather(buf, start + 8, 4, "<u4")[:, 0].astype(np.int64)
        flen = _gather(buf, start + 12, 4, "<u4")[:, 0].astype(np.int64)
        base = start + 4 + (12 + flen + 7) // 8 * 8  # the string starts 12 bytes into the payload
    if np.any(base + _TAIL != start + lens):
        raise ValueError("not the standard sensor_msgs/Imu layout")
    acc = _gather(buf, base + _ACC_AT, 24, "<f8")
    gyro = _gather(buf, base + _GYRO_AT, 24, "<f8")
    vals = np.ascontiguousarray(np.concatenate([acc, gyro], axis=1).T)
    return vals, sec * 1_000_000_000 + nsec
