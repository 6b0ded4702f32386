"""sensor_msgs/Imu messages decoded as arrays (no Python object per message)
give exactly what rosbags' own deserialisers give: message by message in
isolation (every frame_id length to 24, both CDR byte orders, stamps over
the whole int32 range), and through bags written with rosbags' writers
(ROS 1 .bag, ROS 2 .db3 and .mcap) holding two IMU topics of odd frame_id
lengths and a topic of another type. What is not the standard layout
(another definition under the same name, a message of no known layout) is
deserialised by rosbags, never guessed."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest

rosbags = pytest.importorskip("rosbags", reason="the rosbags package reads and writes the bags")
from rosbags.highlevel import AnyReader  # noqa: E402
from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin  # noqa: E402
from rosbags.rosbag2 import Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from imu_allan.errors import InputError  # noqa: E402
from imu_allan.sources import bagdb3, db3pages, imumsg, rosbag  # noqa: E402
from imu_allan.sources.detect import load  # noqa: E402

IMU = "sensor_msgs/msg/Imu"


def _msg(ts: Any, rng: np.random.Generator, i: int, frame: str, sec: int, nsec: int) -> Any:
    T = ts.types
    head: dict[str, Any] = {"stamp": T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), "frame_id": frame}
    if "seq" in T["std_msgs/msg/Header"].__dataclass_fields__:
        head["seq"] = i
    v3 = T["geometry_msgs/msg/Vector3"]
    return T[IMU](
        header=T["std_msgs/msg/Header"](**head),
        orientation=T["geometry_msgs/msg/Quaternion"](*rng.normal(size=4)),
        orientation_covariance=rng.normal(size=9),
        angular_velocity=v3(*rng.normal(size=3)),
        angular_velocity_covariance=rng.normal(size=9),
        linear_acceleration=v3(*rng.normal(size=3)),
        linear_acceleration_covariance=rng.normal(size=9),
    )


def _want(ms: list[Any]) -> tuple[np.ndarray, np.ndarray]:
    """Values (6, k) and stamps (k,) ns from deserialised messages, field by field."""
    vals = [
        [m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z]
        + [m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z]
        for m in ms
    ]
    stamps = [int(m.header.stamp.sec) * 10**9 + int(m.header.stamp.nanosec) for m in ms]
    return np.array(vals, dtype=np.float64).T.reshape(6, -1), np.array(stamps, dtype=np.int64)


@pytest.mark.parametrize("store", [Stores.ROS1_NOETIC, Stores.ROS2_HUMBLE])
def test_arrays_give_what_rosbags_deserialiser_gives(store: Any) -> None:
    ts = get_typestore(store)
    ros1 = store == Stores.ROS1_NOETIC
    rng = np.random.default_rng(5)
    raws = []
    for i in range(150):
        sec, nsec = int(rng.integers(-(2**31), 2**31)), int(rng.integers(0, 2**32))
        m = _msg(ts, rng, i, "f" * (i % 25), sec, nsec)
        little = ros1 or i % 4 != 3  # CDR: every fourth message big-endian
        raws.append(bytes(ts.serialize_ros1(m, IMU) if ros1 else ts.serialize_cdr(m, IMU, little_endian=little)))
    want = _want([ts.deserialize_ros1(r, IMU) if ros1 else ts.deserialize_cdr(r, IMU) for r in raws])
    vals, stamps, odd, keys = imumsg.decode(b"".join(raws), [len(r) for r in raws], ros1)
    assert not odd.any()
    assert np.array_equal(vals, want[0]) and np.array_equal(stamps, want[1])
    assert len(np.unique(keys)) > 3  # several layouts in one block
    same = [raws[7]] * 5  # one layout alone: read in place
    v1, s1, o1, _ = imumsg.decode(b"".join(same), [len(same[0])] * 5, ros1)
    assert not o1.any() and np.array_equal(v1, np.repeat(want[0][:, 7:8], 5, axis=1))


@pytest.mark.parametrize("ros1", [True, False])
def test_a_message_of_no_known_layout_is_left_to_rosbags(ros1: bool) -> None:
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    rng = np.random.default_rng(6)
    good = [
        bytes((ts.serialize_ros1 if ros1 else ts.serialize_cdr)(_msg(ts, rng, i, "imu_link", 7, 9), IMU))
        for i in range(4)
    ]
    longer = good[1] + b"\0" * 8  # its string length no longer gives its length
    bad_len = bytearray(good[2])
    bad_len[12] += 8  # the recorded frame_id length says 8 bytes more (CDR's padding could hide fewer)
    raws = [good[0], longer, bytes(bad_len), good[3], good[0][:20]]
    _, _, odd, _ = imumsg.decode(b"".join(raws), [len(r) for r in raws], ros1)
    assert odd.tolist() == [False, True, True, False, True]
    if not ros1:
        xcdr2 = b"\x00\x07" + good[0][2:]  # another encapsulation: not plain CDR
        assert imumsg.decode(xcdr2, [len(xcdr2)], False)[2].tolist() == [True]


N = 700


def _bag_topics() -> dict[str, str]:
    return {"/imu/a": "a", "/imu/b": "imu_frame_of_odd_len"}  # frame_ids of 1 and 20 bytes


def _write(path: Path, kind: str, compress: bool = False) -> Path:
    """A bag as users' are: two IMU topics (frame_ids of odd lengths, one
    varying midway) and a std_msgs/String topic between them."""
    ros1 = kind == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    rng = np.random.default_rng(8)
    ser = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    if ros1:
        w: Any = Writer1(path)
    else:
        w = Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3)
        if compress:
            w.set_compression(CompressionMode.MESSAGE, CompressionFormat.ZSTD)
    with w:
        conns = {t: w.add_connection(t, IMU, typestore=ts) for t in _bag_topics()}
        text = w.add_connection("/log", "std_msgs/msg/String", typestore=ts)
        for i in range(N):
            t = 1_600_000_000_000_000_000 + i * 2_500_000
            for topic, frame in _bag_topics().items():
                f = frame + ("xyz" if topic.endswith("a") and 300 <= i < 310 else "")
                w.write(conns[topic], t + 1000, ser(_msg(ts, rng, i, f, t // 10**9, t % 10**9), IMU))
            if i % 50 == 0:
                w.write(text, t + 5, ser(ts.types["std_msgs/msg/String"](data="x" * (i % 7)), "std_msgs/msg/String"))
    if kind == "db3":
        return path / f"{path.name}.db3"
    return path / f"{path.name}.mcap" if kind == "mcap" else path


def _rosbags_read(path: Path, topic: str) -> tuple[np.ndarray, np.ndarray]:
    """Every message of ``topic`` deserialised by rosbags, one by one."""
    with AnyReader([path]) as r:
        conns = [c for c in r.connections if c.topic == topic]
        return _want([r.deserialize(raw, c.msgtype) for c, _, raw in r.messages(connections=conns)])


@pytest.mark.parametrize("kind", ["ros1", "db3", "mcap"])
def test_bags_read_as_arrays_equal_rosbags_message_by_message(kind: str, tmp_path: Path) -> None:
    bag = _write(tmp_path / ("run.bag" if kind == "ros1" else "run"), kind)
    backend = rosbag._backend(str(bag), "run")
    assert type(backend).__name__ == {"ros1": "Ros1Backend", "db3": "Db3Backend", "mcap": "McapBackend"}[kind]
    if kind == "db3":  # rosbags' writer's bag: read straight from the table, its plan keeping the order
        con = bagdb3._connect(str(bag))
        assert bagdb3._scans_in_order(con, "timestamp_idx", "timestamp >= ? AND timestamp < ? AND topic_id IN (?)", 1)
        con.close()
    for topic in _bag_topics():
        want_vals, want_stamps = _rosbags_read(bag, topic)
        s = load(str(bag), topic).samples
        got = np.concatenate(list(s.open_blocks()), axis=1)
        assert got.shape == (6, N) and np.array_equal(got, want_vals)
        assert s.fs == pytest.approx(1e9 / 2_500_000, rel=1e-9)
        assert any("/log" in n for n in s.notes)
        backend.choose(topic)
        stamps = np.concatenate([b[1] for b in rosbag._decoded(backend, "run", False)])
        assert np.array_equal(stamps, want_stamps)


WRITTEN_LATE = {
    "in order": [],
    "a row long before the rows around it": [(100, 450)],
    "a row of the burst's stamp after it": [(350, 799)],
    "the first row last": [(0, 799)],
}
"""Rows written out of time order, (row of the time, row it is written after):
the table read along its ids stops before the batch that would let one of
them pass, and the index gives the rest, in rosbags' order."""


def _recorded(late: str) -> list[int]:
    """Times (ns) of 800 rows, 200 of them on one stamp, as written: ``WRITTEN_LATE[late]``."""
    ms = 1_000_000
    recorded = [int(t) for t in np.r_[np.arange(300) * ms, np.full(200, 300 * ms), 300 * ms + np.arange(1, 301) * ms]]
    for row, after in WRITTEN_LATE[late]:
        recorded.insert(after, recorded.pop(row))
    return recorded


@pytest.mark.parametrize("pages", [True, False], ids=["pages", "sqlite"])
@pytest.mark.parametrize("late", WRITTEN_LATE)
def test_db3_batches_of_any_size_and_a_burst_on_one_stamp(late: str, pages: bool, tmp_path: Path, monkeypatch) -> None:
    """Small batches, a range halved around a burst, a timestamp holding more
    than a batch (paged), rows written out of time order, read from the
    file's pages a page at a time or through sqlite: the rows in rosbags'
    order, and the bag's times when the stamps are zero."""
    ts = get_typestore(Stores.ROS2_HUMBLE)
    rng = np.random.default_rng(9)
    path = tmp_path / "burst"
    recorded = _recorded(late)
    with Writer2(path, version=9) as w:
        c = w.add_connection("/imu", IMU, typestore=ts)
        for i, t in enumerate(recorded):
            w.write(c, int(t), ts.serialize_cdr(_msg(ts, rng, i, "imu", 0, 0), IMU))  # stamps left zero
    want_vals, _ = _rosbags_read(path, "/imu")
    with AnyReader([path]) as r:
        want_t = np.array([t for _, t, _ in r.messages()], dtype=np.int64)
    assert np.array_equal(want_t, np.sort(recorded)) and np.array_equal(want_t, recorded) == (late == "in order")
    monkeypatch.setattr(bagdb3, "BATCH", 16)
    monkeypatch.setattr(db3pages, "PIECE", 1)
    if not pages:
        monkeypatch.setattr(db3pages, "_C", None)
    for plan_in_order in (True, False):  # straight from the table, or through an ordered subquery
        monkeypatch.setattr(bagdb3, "_scans_in_order", lambda *_, keep=plan_in_order: keep)
        got = list(bagdb3.batches([str(path / "burst.db3")], "/imu", IMU, True))
        assert max(len(b.lens) for b in got) <= 64 and len(got) > 20
        assert np.array_equal(np.concatenate([b.times for b in got]), want_t)
        raw = b"".join(b.raw for b in got)
        assert np.array_equal(imumsg.decode(raw, np.concatenate([b.lens for b in got]), False)[0], want_vals)
    s = load(str(path)).samples
    assert any("bag's times" in n for n in s.notes)
    assert np.array_equal(np.concatenate(list(s.open_blocks()), axis=1), want_vals)


def test_db3_rows_along_the_table_stop_where_the_order_breaks(tmp_path: Path, monkeypatch) -> None:
    """The table read along its ids (through sqlite) gives batches up to the
    last one that holds every row of its times (counted independently here),
    then says where the index takes over; all along when the table is in time order."""
    monkeypatch.setattr(db3pages, "_C", None)
    ts = get_typestore(Stores.ROS2_HUMBLE)
    rng = np.random.default_rng(3)
    for late in WRITTEN_LATE:
        path = tmp_path / late.replace(" ", "_")
        recorded = _recorded(late)
        with Writer2(path, version=9) as w:
            c = w.add_connection("/imu", IMU, typestore=ts)
            for i, t in enumerate(recorded):
                w.write(c, int(t), ts.serialize_cdr(_msg(ts, rng, i, "imu", 0, 0), IMU))
        con = bagdb3._connect(str(path / f"{path.name}.db3"))
        old, bagdb3.BATCH = bagdb3.BATCH, 16
        try:
            gen, got = bagdb3._in_rowid_order(con, str(path / f"{path.name}.db3"), [1], True, True), []
            while True:
                try:
                    got.append(next(gen).times)
                except StopIteration as stop:
                    where = stop.value
                    break
        finally:
            bagdb3.BATCH = old
            con.close()
        given = np.concatenate(got) if got else np.zeros(0, dtype=np.int64)
        # the longest run of whole batches of 16 rows (by id) sorted, each leaving no later row before its end
        k = 0
        while 16 * (k + 1) <= len(recorded):
            nxt = recorded[: 16 * (k + 1)]
            if np.any(np.diff(nxt) < 0) or min(recorded[16 * (k + 1) :] or [np.inf]) < nxt[-1]:
                break
            k += 1
        if 16 * k >= len(recorded):
            assert where is None and np.array_equal(given, recorded)
        else:
            assert np.array_equal(given, recorded[: 16 * k])
            assert where == ((int(recorded[16 * k - 1]) if k else None), 16 * k + 1)


def test_db3_pages_give_sqlite_rows_and_stop_before_a_row_that_spills(tmp_path: Path, monkeypatch) -> None:
    """The leaf pages read by the compiled reader give the IMU topic's rows in
    id order as sqlite gives them, another topic's rows that spill to
    overflow pages skipped; they stop before an IMU message that spills (a
    frame_id of 6000 bytes) and say where; the bag still reads as rosbags reads it."""
    if db3pages._C is None:
        pytest.skip("the compiled page reader is not built (make ext)")
    monkeypatch.setattr(db3pages, "PIECE", 1)
    ts = get_typestore(Stores.ROS2_HUMBLE)
    rng = np.random.default_rng(5)
    path = tmp_path / "spill"
    with Writer2(path, version=9) as w:
        imu = w.add_connection("/imu", IMU, typestore=ts)
        log = w.add_connection("/log", "std_msgs/msg/String", typestore=ts)
        for i in range(3000):
            t = 10**9 + i * 1_000_000
            frame = "f" * 6000 if i == 2500 else "imu"
            w.write(imu, t, ts.serialize_cdr(_msg(ts, rng, i, frame, t // 10**9, t % 10**9), IMU))
            if i % 100 == 0:
                text = ts.types["std_msgs/msg/String"](data="x" * (5000 + i))
                w.write(log, t + 1, ts.serialize_cdr(text, "std_msgs/msg/String"))
    db = str(path / "spill.db3")
    con = bagdb3._connect(db)
    rows = con.execute("SELECT id, timestamp, data FROM messages WHERE topic_id = 1 ORDER BY id").fetchall()
    spill = next(i for i, r in enumerate(rows) if len(r[2]) > 6000)
    gen, got = db3pages.along(db, con, [1], 1), []
    while True:
        try:
            got.append(next(gen))
        except StopIteration as stop:
            where = stop.value
            break
    con.close()
    assert rows[spill - 20][0] < where <= rows[spill][0]  # stopped at the page holding it
    given = [r for r in rows if r[0] < where]
    assert b"".join(bytes(g.raw) for g in got) == b"".join(r[2] for r in given)
    assert np.array_equal(np.concatenate([g.times for g in got]), [r[1] for r in given])
    assert np.array_equal(np.concatenate([g.lens for g in got]), [len(r[2]) for r in given])
    assert got[-1].after == where
    want_vals, want_stamps = _rosbags_read(path, "/imu")
    s = load(str(path), "/imu").samples
    assert np.array_equal(np.concatenate(list(s.open_blocks()), axis=1), want_vals)


def test_db3_page_reader_refuses_what_is_not_a_table_leaf_and_never_reads_past_a_page(tmp_path: Path) -> None:
    """A real leaf page gives sqlite's rows; its type byte changed, a cell
    pointer past the page, a record header claiming another column: refused
    (a negative status, the rest read by sqlite); random pages never give a
    row longer than the page or crash the process."""
    if db3pages._C is None:
        pytest.skip("the compiled page reader is not built (make ext)")
    db = _write(tmp_path / "run", "db3")
    con = bagdb3._connect(str(db))
    with open(db, "rb") as f:
        leaves, size, usable = db3pages._leaves(f.fileno(), con)
        page = np.frombuffer(os.pread(f.fileno(), size, (int(leaves[0]) - 1) * size), dtype=np.uint8).copy()
    want = np.ones(8, dtype=np.uint8)

    def read(pg: np.ndarray) -> tuple[int, list[tuple[int, int, bytes]]]:
        raw, cap = np.empty(size, dtype=np.uint8), size // 4
        lens, times, ids = (np.zeros(cap, dtype=np.int64) for _ in range(3))
        st, k, nb, _, _ = db3pages._C.leaf_rows(
            pg, np.zeros(1, dtype=np.int64), size, usable, want, -(2**63), raw, lens, times, ids
        )
        assert 0 <= k <= cap and nb == lens[:k].sum() <= size and np.all(lens[:k] < size)
        at = np.cumsum(lens[:k]) - lens[:k]
        return st, [(int(ids[i]), int(times[i]), raw[at[i] : at[i] + lens[i]].tobytes()) for i in range(k)]

    status, rows = read(page)
    n = int(page[3]) << 8 | int(page[4])
    assert (
        status == 0
        and rows == con.execute("SELECT id, timestamp, data FROM messages ORDER BY id LIMIT ?", (n,)).fetchall()
    )
    con.close()
    bad = page.copy()
    bad[0] = 10  # an index's leaf
    assert read(bad)[0] == -1
    bad = page.copy()
    bad[8:10] = [0xFF, 0xFF]  # the first cell beyond the page
    assert read(bad)[0] == -2
    cell = int(page[8]) << 8 | int(page[9])
    assert page[cell] >= 0x80 > page[cell + 1] and page[cell + 2] < 0x80  # size: 2 bytes, rowid: 1, then the record
    assert list(page[cell + 3 : cell + 6]) == [6, 0, 9]  # a header of 6 bytes: id NULL, topic_id the constant 1
    bad = page.copy()
    bad[cell + 5] = 7  # topic_id a float
    assert read(bad)[0] == -2
    rng = np.random.default_rng(1)
    for _ in range(300):
        junk = rng.integers(0, 256, size, dtype=np.uint8)
        junk[0], junk[3], junk[4] = 13, 0, rng.integers(1, 40)
        assert read(junk)[0] in (0, -2, -3, -4, -5)


def test_a_compressed_bag_is_read_by_rosbags(tmp_path: Path) -> None:
    bag = _write(tmp_path / "zrun", "db3", compress=True).parent
    assert isinstance(rosbag._backend(str(bag), "zrun"), rosbag.RosbagsBackend)
    want, _ = _rosbags_read(bag, "/imu/a")
    assert np.array_equal(np.concatenate(list(load(str(bag), "/imu/a").samples.open_blocks()), axis=1), want)


def test_an_mcap_of_zstd_chunks_and_times_out_of_order(tmp_path: Path) -> None:
    """Chunks compressed by the storage, messages logged out of time order
    within a chunk (rosbags sorts each chunk by log time), another topic of the
    same length in between: the same messages in the same order as rosbags."""
    ts = get_typestore(Stores.ROS2_HUMBLE)
    rng = np.random.default_rng(12)
    path = tmp_path / "z"
    w = Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP)
    w.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with w:
        a, b = (w.add_connection(t, IMU, typestore=ts) for t in ("/imu", "/imu2"))
        for i in range(3000):
            t = 10**9 + i * 1_000_000 + (1_500_000 if i % 97 == 5 else 0)  # some logged after the next
            for c in (a, b) if i % 3 else (a,):
                w.write(c, t, ts.serialize_cdr(_msg(ts, rng, i, "imu", 1, i), IMU))
    backend = rosbag._backend(str(path), "z")
    assert type(backend).__name__ == "McapBackend"
    want, want_stamps = _rosbags_read(path, "/imu")
    backend.choose("/imu")
    got = list(rosbag._decoded(backend, "z", True))
    assert np.array_equal(np.concatenate([g[0] for g in got], axis=1), want)
    assert np.array_equal(np.concatenate([g[1] for g in got]), want_stamps)
    with AnyReader([path]) as r:
        want_t = [t for c, t, _ in r.messages() if c.topic == "/imu"]
    assert np.array_equal(np.concatenate([g[2] for g in got]), want_t)
    assert np.all(np.diff(want_t) >= 0)  # sorted, though 31 were logged after the next message


def _ros1_bag(path: Path, fmt: Any, chunk: int, late: int) -> Path:
    """Chunks of about ``chunk`` bytes (compressed or not), every ``late``-th
    message written after the next one (0: none), a second IMU topic of the
    same layout in between."""
    ts = get_typestore(Stores.ROS1_NOETIC)
    rng = np.random.default_rng(13)
    w = Writer1(path)
    if fmt:
        w.set_compression(getattr(Writer1.CompressionFormat, fmt))
    w.chunk_threshold = chunk
    with w:
        a, b = (w.add_connection(t, IMU, typestore=ts) for t in ("/imu", "/imu2"))
        for i in range(2000):
            t = 10**9 + i * 1_000_000 + (1_500_000 if late and i % late == 5 else 0)
            for c in (a, b) if i % 3 else (a,):
                w.write(c, t, ts.serialize_ros1(_msg(ts, rng, i, "imu", 1, i), IMU))
    return path


@pytest.mark.parametrize("fmt", [None, "BZ2", "LZ4"])
@pytest.mark.parametrize("chunk, late", [(20_000, 0), (1 << 30, 41), (20_000, 41)])
def test_a_ros1_bag_of_many_chunks_compressed_and_times_out_of_order(
    fmt: Any, chunk: int, late: int, tmp_path: Path
) -> None:
    """Many small chunks, or one chunk of messages out of time order (rosbags
    orders by time, then chunk, then place): what rosbags gives, in its order.
    Chunks whose times overlap are left to rosbags."""
    from rosbags.rosbag1 import Reader as Reader1

    path = _ros1_bag(tmp_path / "c.bag", fmt, chunk, late)
    with Reader1(path) as r:
        spans = [(c.start_time, c.end_time) for c in r.chunk_infos]
    overlap = any(b[0] < a[1] - 1 for a, b in zip(spans, spans[1:]))  # rosbags' end: the last time + 1
    assert overlap == (chunk < 1 << 30 and late > 0)  # as this bag was written to be
    backend = rosbag._backend(str(path), "c")
    assert type(backend).__name__ == ("RosbagsBackend" if overlap else "Ros1Backend")
    want, want_stamps = _rosbags_read(path, "/imu")
    backend.choose("/imu")
    assert backend.count == 2000
    got = list(rosbag._decoded(backend, "c", True))
    assert np.array_equal(np.concatenate([g[0] for g in got], axis=1), want)
    assert np.array_equal(np.concatenate([g[1] for g in got]), want_stamps)
    with AnyReader([path]) as r:
        want_t = [t for c, t, _ in r.messages() if c.topic == "/imu"]
    assert np.array_equal(np.concatenate([g[2] for g in got]), want_t)


def test_a_bad_message_stops_the_reading_thread_with_one_line(tmp_path: Path, monkeypatch) -> None:
    """A value that is not finite (found as the blocks are handed over) and a
    truncated message (found by the thread reading ahead) name their message;
    the thread ends either way."""
    import sqlite3
    import threading

    ts = get_typestore(Stores.ROS2_HUMBLE)
    rng = np.random.default_rng(14)
    path = tmp_path / "bad"
    with Writer2(path, version=9) as w:
        c = w.add_connection("/imu", IMU, typestore=ts)
        for i in range(3000):
            m = _msg(ts, rng, i, "imu", 1 + i // 1000, (i % 1000) * 1_000_000)
            if i == 1234:
                m.angular_velocity.y = float("nan")
            w.write(c, 10**9 + i * 1_000_000, ts.serialize_cdr(m, IMU))
    monkeypatch.setattr(bagdb3, "BATCH", 64)
    before = threading.active_count()
    with pytest.raises(InputError, match="message 1235: a value is not a finite number"):
        list(load(str(path)).samples.open_blocks())
    with sqlite3.connect(path / "bad.db3") as con:
        con.execute("UPDATE messages SET data = (SELECT data FROM messages WHERE id = 1234) WHERE id = 1235")
        con.execute("UPDATE messages SET data = substr(data, 1, 20) WHERE id = 2001")
    with pytest.raises(InputError, match="message 2001 is not a readable sensor_msgs/Imu"):
        list(load(str(path)).samples.open_blocks())
    assert threading.active_count() == before


CUSTOM = """std_msgs/Header header
geometry_msgs/Vector3 angular_velocity
geometry_msgs/Vector3 linear_acceleration
float64 temperature
"""


@pytest.mark.parametrize("ros1", [True, False])
def test_another_definition_named_sensor_msgs_imu_is_deserialised_by_rosbags(ros1: bool, tmp_path: Path) -> None:
    """A driver's own message under the standard name: its bytes are not the
    standard layout, so every message goes through rosbags with the bag's
    definition, and the values are the ones written."""
    from rosbags.typesys import get_types_from_msg

    std = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    ts = get_typestore(Stores.EMPTY)
    deps = ["builtin_interfaces/msg/Time", "std_msgs/msg/Header", "geometry_msgs/msg/Vector3"]
    ts.register({k: std.fielddefs[k] for k in deps})
    ts.register(get_types_from_msg(CUSTOM, IMU))
    T = ts.types
    rng = np.random.default_rng(10)
    vals = rng.normal(size=(6, 40))
    path = tmp_path / ("c.bag" if ros1 else "c")
    w: Any = Writer1(path) if ros1 else Writer2(path, version=9)
    with w:
        c = w.add_connection("/imu", IMU, typestore=ts)
        for i in range(40):
            head: dict[str, Any] = {"stamp": T["builtin_interfaces/msg/Time"](sec=1, nanosec=i * 5_000_000)}
            head["frame_id"] = "imu"
            if ros1:
                head["seq"] = i
            v3 = T["geometry_msgs/msg/Vector3"]
            m = T[IMU](T["std_msgs/msg/Header"](**head), v3(*vals[3:, i]), v3(*vals[:3, i]), 21.5)
            w.write(c, i * 5_000_000, (ts.serialize_ros1 if ros1 else ts.serialize_cdr)(m, IMU))
    got = np.concatenate(list(load(str(path)).samples.open_blocks()), axis=1)
    assert np.array_equal(got, vals)


@pytest.mark.parametrize(
    "name, head", [("x.db3", b"SQLite format 3\0"), ("x.mcap", b"\x89MCAP0\r\n"), ("x.bag", b"#ROSBAG V2.0\n")]
)
def test_a_damaged_bag_is_one_line_not_a_traceback(name: str, head: bytes, tmp_path: Path) -> None:
    path = tmp_path / name
    path.write_bytes(head + bytes(range(256)) * 20)
    with pytest.raises(InputError, match="not a readable ROS bag"):
        list(load(str(path)).samples.open_blocks())
