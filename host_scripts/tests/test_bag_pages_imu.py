"""A ROS 2 sqlite3 bag's sensor_msgs/Imu messages decoded by the compiled
page reader straight from the file's leaf pages (no copy of their bytes):
message by message what the array decoder (imumsg.decode, itself checked
against rosbags' deserialiser) gives on the bytes sqlite returns, whatever
the layout (both CDR byte orders, every frame_id length to 24, another
encapsulation, a string length that does not fit, a message too short);
through a whole bag, rosbags' values; and an analysis of such a bag, streamed
or in memory, reports the numbers an analysis of the same samples saved as a
.npy reports."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

pytest.importorskip("rosbags")
from rosbags.rosbag2 import Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402
from test_bag_decode import IMU, _msg, _rosbags_read  # noqa: E402

from imu_allan.sources import bagdb3, db3pages, imumsg, rosbag  # noqa: E402
from imu_allan.sources.detect import load  # noqa: E402


def _needs_reader() -> None:
    if db3pages._C is None:
        pytest.skip("the compiled page reader is not built (make ext)")


def _layouts(ts: Any, rng: np.random.Generator, n: int) -> list[bytes]:
    """Messages of every layout the decoder meets, the standard ones most often."""
    out = []
    for i in range(n):
        t = 10**9 + i * 1_000_000
        m = _msg(ts, rng, i, "f" * (i % 25), t // 10**9, t % 10**9)
        raw = bytes(ts.serialize_cdr(m, IMU, little_endian=i % 5 != 2))
        if i % 97 == 13:
            raw = b"\x00\x07" + raw[2:]  # another encapsulation (XCDR2)
        elif i % 97 == 31:
            bad = bytearray(raw)
            bad[12 if raw[1] else 15] ^= 8  # frame_id's recorded length no longer gives the total
            raw = bytes(bad)
        elif i % 97 == 50:
            raw = raw[:20]
        elif i % 97 == 70:
            raw = raw + b"\0" * 8
        out.append(raw)
    return out


def test_page_decoder_gives_the_array_decoders_results_on_every_layout(tmp_path: Path, monkeypatch) -> None:
    _needs_reader()
    monkeypatch.setattr(db3pages, "PIECE", 3)  # many pieces, a row's page never split
    ts = get_typestore(Stores.ROS2_HUMBLE)
    rng = np.random.default_rng(21)
    raws = _layouts(ts, rng, 1500)
    path = tmp_path / "layouts"
    with Writer2(path, version=9) as w:
        imu = w.add_connection("/imu", IMU, typestore=ts)
        log = w.add_connection("/log", "std_msgs/msg/String", typestore=ts)
        for i, raw in enumerate(raws):
            w.write(imu, 10**9 + i * 1_000_000, raw)
            if i % 40 == 0:
                w.write(
                    log,
                    10**9 + i * 1_000_000 + 1,
                    ts.serialize_cdr(ts.types["std_msgs/msg/String"]("x"), "std_msgs/msg/String"),
                )
    db = str(path / "layouts.db3")
    con = bagdb3._connect(db)
    rows = con.execute("SELECT id, timestamp, data FROM messages WHERE topic_id = 1 ORDER BY id").fetchall()
    gen, got = db3pages.along(db, con, [1], 1, imu=True, join=100), []
    while True:
        try:
            got.append(next(gen))
        except StopIteration as stop:
            assert stop.value is None  # every row read from the pages
            break
    con.close()
    assert len(got) > 10 and all(g.imu is not None and len(g.raw) == 0 for g in got)
    assert all(100 <= len(g.lens) < 100 + 3 * 12 for g in got[:-1])  # 12 messages a page at most
    data = [r[2] for r in rows]
    vals, stamps, odd, keys = imumsg.decode(b"".join(data), [len(d) for d in data], False)
    cat = {f: np.concatenate([getattr(g.imu, f) for g in got], axis=-1) for f in db3pages.Decoded._fields}
    assert np.array_equal(cat["ids"], [r[0] for r in rows])
    assert np.array_equal(np.concatenate([g.times for g in got]), [r[1] for r in rows])
    assert np.array_equal(np.concatenate([g.lens for g in got]), [len(d) for d in data])
    assert np.array_equal(cat["odd"], odd) and np.array_equal(cat["keys"], keys)
    assert 0 < odd.sum() < len(odd) / 10 and len(np.unique(keys[~odd])) == 8  # 4 padded lengths, 2 orders
    long_ = np.array([len(d) >= imumsg.CDR_FIXED + 16 for d in data])  # the rest: zeros in both
    assert np.array_equal(cat["stamps"][long_], stamps[long_]) and np.array_equal(cat["vals"], vals)
    want = _want_good(ts, data, odd)
    assert np.array_equal(cat["vals"][:, ~odd], want[0]) and np.array_equal(cat["stamps"][~odd], want[1])


def _want_good(ts: Any, data: list[bytes], odd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """rosbags' values and stamps of the messages of the standard layout."""
    from test_bag_decode import _want

    return _want([ts.deserialize_cdr(d, IMU) for d, o in zip(data, odd) if not o])


def test_a_bag_of_both_byte_orders_reads_from_its_pages_as_rosbags_reads_it(tmp_path: Path, monkeypatch) -> None:
    """Read as a user's bag is: the pages decoded (counted), the first
    message of each layout checked against rosbags with its bytes from sqlite."""
    _needs_reader()
    ts = get_typestore(Stores.ROS2_HUMBLE)
    rng = np.random.default_rng(22)
    path = tmp_path / "orders"
    with Writer2(path, version=9) as w:
        c = w.add_connection("/imu", IMU, typestore=ts)
        for i in range(5000):
            t = 10**9 + i * 2_500_000
            m = _msg(ts, rng, i, "imu" + "x" * (i // 1000), t // 10**9, t % 10**9)
            w.write(c, t, ts.serialize_cdr(m, IMU, little_endian=(i // 700) % 2 == 0))
    decoded, fetched = [], []
    real_rows, real_fetcher = db3pages._imu_rows, bagdb3._fetcher
    monkeypatch.setattr(db3pages, "_imu_rows", lambda *a: decoded.append(1) or real_rows(*a))

    def fetcher(con: Any) -> Any:
        one = real_fetcher(con)
        return lambda ids: lambda i: fetched.append(int(ids[i])) or one(ids)(i)

    monkeypatch.setattr(bagdb3, "_fetcher", fetcher)
    want_vals, want_stamps = _rosbags_read(path, "/imu")
    got = np.concatenate(list(load(str(path)).samples.open_blocks()), axis=1)
    assert np.array_equal(got, want_vals) and decoded
    assert 1 <= len(fetched) <= 12  # one message of each layout (length, byte order): no more
    calls = len(decoded)  # a reader built before it decoded messages: their bytes, decoded by numpy
    copied: list[int] = []
    real = db3pages._C.leaf_rows
    monkeypatch.setattr(db3pages, "_C", SimpleNamespace(leaf_rows=lambda *a: copied.append(1) or real(*a)))
    assert np.array_equal(np.concatenate(list(load(str(path)).samples.open_blocks()), axis=1), want_vals)
    assert len(decoded) == calls and copied  # still from the pages
    monkeypatch.undo()
    backend = rosbag._backend(str(path), "orders")
    backend.choose("/imu")
    assert np.array_equal(np.concatenate([b[1] for b in rosbag._decoded(backend, "orders", False)]), want_stamps)


def test_a_bag_analysed_streamed_or_in_memory_reports_what_its_samples_as_npy_report(run_cli, tmp_path: Path) -> None:
    """The same float64 samples, from a bag's pages and from a .npy (another
    reader): every statistic equal, streamed (--memory 1) and in memory."""
    _needs_reader()
    from test_streaming import _both, _walk

    ts = get_typestore(Stores.ROS2_HUMBLE)
    rng = np.random.default_rng(23)
    n = 30_000
    x = np.cumsum(rng.normal(size=(6, n)) * 1e-3, axis=1) + rng.normal(size=(6, n)) * 0.05
    x[:3] += [[0.1], [-0.2], [9.81]]
    path = tmp_path / "same"
    T = ts.types
    v3 = T["geometry_msgs/msg/Vector3"]
    with Writer2(path, version=9) as w:
        c = w.add_connection("/imu", IMU, typestore=ts)
        for i in range(n):
            t = 10**9 + i * 2_500_000
            m = _msg(ts, rng, i, "imu", t // 10**9, t % 10**9)
            m.linear_acceleration, m.angular_velocity = v3(*x[:3, i]), v3(*x[3:, i])
            w.write(c, t, ts.serialize_cdr(m, IMU))
    npy = tmp_path / "same.npy"
    np.save(npy, np.vstack([np.arange(n) * 0.0025, x]).T)
    bag_mem, bag_streamed = _both(run_cli, path)
    npy_mem, _ = _both(run_cli, npy)
    assert any("streamed" in s for s in bag_streamed["notes"]) and not any("streamed" in s for s in bag_mem["notes"])
    diffs: list = []
    _walk({k: v for k, v in bag_mem.items() if k != "notes"}, bag_streamed, "", diffs)
    assert diffs == [] and bag_mem["warmup"] == bag_streamed["warmup"]
    for ch, c in bag_mem["channels"].items():  # the rate from ns stamps or float seconds: tau to the last bit
        other = npy_mem["channels"][ch]
        for stat, points in c["curves"].items():
            assert [{k: v for k, v in p.items() if k != "tau_s"} for p in points] == [
                {k: v for k, v in p.items() if k != "tau_s"} for p in other["curves"][stat]
            ]
            assert [p["tau_s"] for p in points] == pytest.approx([p["tau_s"] for p in other["curves"][stat]], rel=1e-12)
        _close(c["terms"], other["terms"])
        _close(c["overbound"], other["overbound"])


def _close(a: Any, b: Any) -> None:
    """Equal, numbers to 1e-9 relative (the fits' taus differ in their last
    bit, the fitted values from the 12th digit on)."""
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            _close(a[k], b[k])
    elif isinstance(a, list):
        assert len(a) == len(b)
        for u, v in zip(a, b):
            _close(u, v)
    elif isinstance(a, float):
        assert a == pytest.approx(b, rel=1e-9, abs=0)
    else:
        assert a == b
