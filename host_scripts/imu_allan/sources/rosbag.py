"""ROS 1 and ROS 2 bags: the sensor_msgs/Imu messages of one topic, block by block.

Read with the ``rosbags`` library (pure Python, no ROS install): a ROS 1
``.bag``, a ROS 2 bag folder (metadata.yaml beside its storage), or its
``.db3`` (sqlite3) or ``.mcap`` file alone. ``angular_velocity`` (rad/s) and
``linear_acceleration`` (m/s^2) become gx gy gz and ax ay az, in the units the
message defines (REP 103), so no --scale is needed; the header stamps give
the sample rate and the gaps (timing.py), or, when a driver leaves them zero,
the times the bag recorded the messages.

Messages are never deserialised one by one in Python: their raw bytes come
in bulk (a ROS 2 sqlite3 bag from its file's pages or sqlite, bagdb3.py; an MCAP and a
ROS 1 bag chunk by chunk, bagmcap.py and bagros1.py; anything else, such as a
bag compressed as a whole, through rosbags' reader) and are decoded as
arrays (imumsg.py; a ROS 2 sqlite3 bag's pages are decoded so by the
compiled page reader itself, db3pages.py, no message's bytes copied, and
sqlite gives the bytes of the few messages checked or deserialised). One
message of each layout (length, byte order) is also
deserialised by rosbags, and a disagreement (a message definition not the
standard one), like a message of no known layout, is deserialised by
rosbags, message by message.
"""

from __future__ import annotations

import os
import queue
import threading
from functools import lru_cache
from itertools import islice
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Callable, Iterator, NamedTuple, Optional

import numpy as np

from ..channels import CHANNELS
from ..errors import InputError
from . import bagdb3, bagmcap, bagros1, imumsg
from .timing import rate_from_time

IMU_TYPE = "sensor_msgs/msg/Imu"
BLOCK_MESSAGES = 1 << 16
"""Messages rosbags' reader hands over before they are decoded: about 20 MB."""
SNIFF_MESSAGES = 2048
"""Messages whose stamps give the sample rate before the pass."""
UNITS = {ch: ("rad/s" if ch[0] == "g" else "m/s^2") for ch in CHANNELS}


class Raw(NamedTuple):
    raw: bytes  # messages end to end (empty when ``imu``)
    lens: np.ndarray  # (k,)
    times: Optional[np.ndarray]  # (k,) the bag's times, ns (when asked)
    imu: Any = None  # db3pages.Decoded: the messages decoded already (imumsg.decode's results)
    fetch: Optional[Callable[[int], bytes]] = None  # with ``imu``: message i's bytes


class Backend:
    """Where a topic's raw messages come from: ``open_raw(times, limit)``
    yields Raw blocks; ``deserialize(raw)`` is rosbags' message."""

    ros1 = False
    topics: list[tuple[str, str]] = []  # (topic, message type) of every connection
    count = 0

    def open_raw(self, times: bool, limit: Optional[int] = None) -> Iterator[Raw]:
        raise NotImplementedError

    def deserialize(self, raw: bytes) -> Any:
        raise NotImplementedError


@lru_cache(maxsize=2)
def _store(ros1: bool) -> Any:
    """rosbags' typestore of the standard messages (building one takes ~0.2 s)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)


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


class RosbagsBackend(Backend):
    """rosbags' reader (ROS 1 .bag, .mcap, compressed or unusual ROS 2 bags): raw bytes per message."""

    msgtype = IMU_TYPE  # the topic's message type

    def __init__(self, path: str, name: str) -> None:
        self.path, self.name = path, name
        r = _reader(path, name)
        try:
            self.topics = [(c.topic, c.msgtype) for c in r.connections]
        finally:
            r.close()
        self.topic: Optional[str] = None
        self._deser: Optional[Callable[[bytes], Any]] = None

    def choose(self, topic: str) -> None:
        r = _reader(self.path, self.name)
        try:
            conns = _conns(r, topic, self.msgtype)
            self.topic, self.count, self.ros1 = topic, sum(c.msgcount for c in conns), _is_ros1(conns[0])
            self._chosen(r, conns)
        finally:
            r.close()

    def _chosen(self, reader: Any, conns: list[Any]) -> None:
        """What a subclass learns from the chosen topic (its reader open)."""

    def _read(self, m: Any) -> Any:
        """The sensor_msgs/Imu of a deserialised message."""
        return m

    def open_raw(self, times: bool, limit: Optional[int] = None) -> Iterator[Raw]:
        r = _reader(self.path, self.name)
        self._deser = lambda raw: self._read(r.deserialize(raw, self.msgtype))
        try:
            yield from _blocks(r.messages(connections=_conns(r, str(self.topic), self.msgtype)), limit)
        finally:
            r.close()

    def deserialize(self, raw: bytes) -> Any:
        assert self._deser is not None
        return self._deser(raw)


class McapBackend(RosbagsBackend):
    """A ROS 2 MCAP bag (uncompressed as a bag; its chunks may be): rosbags'
    chunk index and decompression, the records found as arrays (bagmcap.py)."""

    def __init__(self, path: str, name: str) -> None:
        super().__init__(path, name)
        self.ros1 = False

    @staticmethod
    def fits(path: str) -> bool:
        """A bag whose every storage is an indexed MCAP with chunks in time order."""
        from rosbags.rosbag2 import Reader

        try:
            with Reader(path) as r:
                storages = _mcap_storages(r)
                return bool(storages) and all(bagmcap.chunks_in_order(s) for s in storages)
        except Exception:  # rosbags will say what is wrong
            return False

    def choose(self, topic: str) -> None:
        super().choose(topic)
        self.ros1 = False

    def open_raw(self, times: bool, limit: Optional[int] = None) -> Iterator[Raw]:
        from rosbags.rosbag2 import Reader

        r = _reader(self.path, self.name)
        self._deser = lambda raw: r.deserialize(raw, IMU_TYPE)
        try:
            with Reader(self.path) as bag:
                chunks = (
                    chunk
                    for st in _mcap_storages(bag)
                    for ids in [{c.id for c in st.connections if c.topic == self.topic and c.msgtype == IMU_TYPE}]
                    for chunk in (bagmcap.chunk_messages(st, ids) if ids else ())
                )
                yield from _first(chunks, limit)
        finally:
            r.close()


def _blocks(messages: Iterator[tuple[Any, int, bytes]], limit: Optional[int]) -> Iterator[Raw]:
    """rosbags' (connection, time, bytes) messages as Raw blocks, the first ``limit`` of them (all: None)."""
    raws: list[bytes] = []
    stamps: list[int] = []
    for _, t, raw in islice(messages, limit):
        raws.append(raw)
        stamps.append(t)
        if len(raws) == BLOCK_MESSAGES:
            yield _raw(raws, stamps)
            raws, stamps = [], []
    if raws:
        yield _raw(raws, stamps)


def _first(chunks: Iterator[tuple[bytes, np.ndarray, np.ndarray]], limit: Optional[int]) -> Iterator[Raw]:
    """The chunks' messages as ``Raw`` blocks, the first ``limit`` of them (all: None)."""
    left = limit
    for raw, lens, t in chunks:
        if left is not None:
            raw, lens, t = raw[: int(lens[:left].sum())], lens[:left], t[:left]
            left -= len(lens)
        yield Raw(raw, lens, t)
        if left is not None and left <= 0:
            return


class CarrierBackend(RosbagsBackend):
    """A driver's own message that holds one sensor_msgs/Imu field (e.g. a
    VectorNav driver's {header, imu, mag_field, ...}): every message is
    deserialised by rosbags with the bag's own definitions, and the field is
    read as the IMU message. Its stamps are the field's header's, or, where
    those are not valid times (nanosec past a second), the message's own
    header's."""

    def __init__(self, path: str, name: str, msgtype: str, field: str) -> None:
        super().__init__(path, name)
        self.msgtype, self.field, self.outer_stamps = msgtype, field, False

    def _chosen(self, reader: Any, conns: list[Any]) -> None:
        first = next(iter(reader.messages(connections=conns)), None)
        if first is not None:
            m = reader.deserialize(first[2], self.msgtype)
            inner = getattr(m, self.field).header.stamp
            self.outer_stamps = not _valid(inner) and _valid(getattr(getattr(m, "header", None), "stamp", None))

    def _read(self, m: Any) -> Any:
        return _lift(m, self.field, self.outer_stamps)


def _valid(stamp: Any) -> bool:
    """A header stamp that is a time: nanoseconds within a second, not zero."""
    return stamp is not None and 0 <= int(stamp.nanosec) < 1_000_000_000 and (stamp.sec, stamp.nanosec) != (0, 0)


def _lift(m: Any, field: str, outer: bool) -> Any:
    """The sensor_msgs/Imu field of a driver's message, stamped by the message's own header when ``outer``."""
    inner = getattr(m, field)
    if not outer:
        return inner
    return SimpleNamespace(
        header=m.header, angular_velocity=inner.angular_velocity, linear_acceleration=inner.linear_acceleration
    )


def carriers(path: str, name: str) -> dict[str, tuple[str, str]]:
    """Topics whose message type holds exactly one sensor_msgs/Imu field, read
    from the bag's own definitions: topic -> (message type, field)."""
    r = _reader(path, name)
    try:
        found = {}
        for c in r.connections:
            fields = r.typestore.fielddefs.get(c.msgtype, ((), []))[1] if c.msgtype != IMU_TYPE else []
            imu = [f for f, (_, sub) in fields if sub == IMU_TYPE]
            if len(imu) == 1:
                found[c.topic] = (c.msgtype, imu[0])
        return found
    finally:
        r.close()


class Ros1Backend(Backend):
    """A ROS 1 bag read through its own index (bagros1.py); rosbags' ROS 1
    typestore deserialises what the arrays do not decode."""

    ros1 = True

    def __init__(self, path: str, bag: bagros1.Bag) -> None:
        self.path, self.bag, self.topic = path, bag, ""
        self.topics = [(c.topic, c.msgtype) for c in bag.conns]
        self._ts = _store(ros1=True)

    @staticmethod
    def read_index(path: str) -> Optional[bagros1.Bag]:
        """The bag's index when it is read so: standard sensor_msgs/Imu definitions, chunks in time order."""
        try:
            with open(path, "rb") as f:
                bag = bagros1.open_bag(f)
        except Exception:  # rosbags says what is wrong
            return None
        std = _store(ros1=True).generate_msgdef(IMU_TYPE)[1]
        return bag if bag is not None and all(c.md5sum == std for c in bag.conns if c.msgtype == IMU_TYPE) else None

    def _ids(self) -> set[int]:
        return {c.id for c in self.bag.conns if c.topic == self.topic and c.msgtype == IMU_TYPE}

    def choose(self, topic: str) -> None:
        self.topic = topic
        self.count = sum(self.bag.counts.get(i, 0) for i in self._ids())

    def open_raw(self, times: bool, limit: Optional[int] = None) -> Iterator[Raw]:
        with open(self.path, "rb") as f:
            yield from _first(bagros1.chunk_messages(f, self.bag, self._ids()), limit)

    def deserialize(self, raw: bytes) -> Any:
        return self._ts.deserialize_ros1(raw, IMU_TYPE)


def _mcap_storages(reader: Any) -> list[Any]:
    """The MCAP storages of an open rosbags Reader (none when another, or compressed as a bag)."""
    st = reader.storage
    if type(st).__name__ == "McapReader":
        return [st]
    meta = getattr(st, "metadata", None)
    subs = list(getattr(st, "storages", []))
    if meta is None or meta.compression_mode or not subs or any(type(s).__name__ != "McapReader" for s in subs):
        return []
    return subs


def _conns(reader: Any, topic: str, msgtype: str = IMU_TYPE) -> list[Any]:
    return [c for c in reader.connections if c.topic == topic and c.msgtype == msgtype]


def _is_ros1(conn: Any) -> bool:
    return type(conn.ext).__name__ == "ConnectionExtRosbag1"


def _raw(raws: list[bytes], times: list[int]) -> Raw:
    lens = np.fromiter(map(len, raws), dtype=np.int64, count=len(raws))
    return Raw(b"".join(raws), lens, np.asarray(times, dtype=np.int64))


class Db3Backend(Backend):
    """A ROS 2 sqlite3 bag read by sqlite in bulk (bagdb3.py); rosbags' own
    typestore deserialises what the arrays do not decode."""

    def __init__(self, paths: list[str], listing: list[tuple[str, str, str]]) -> None:
        self.paths, self.topics = paths, [(n, t) for n, t, _ in listing]
        self.topic = ""
        self._ts = _store(ros1=False)

    def choose(self, topic: str) -> None:
        self.topic, self.count = topic, bagdb3.count(self.paths, topic, IMU_TYPE)

    def open_raw(self, times: bool, limit: Optional[int] = None) -> Iterator[Raw]:
        for b in bagdb3.batches(self.paths, self.topic, IMU_TYPE, times, limit, imu=True):
            yield Raw(b.raw, b.lens, b.times, b.imu, b.fetch)

    def deserialize(self, raw: bytes) -> Any:
        return self._ts.deserialize_cdr(raw, IMU_TYPE)


def _backend(path: str, name: str) -> Backend:
    """sqlite straight when the bag is a plain ROS 2 sqlite3 bag whose
    sensor_msgs/Imu is the standard one (its type hash, when it records
    one), rosbags otherwise."""
    paths = bagdb3.files(path)
    if paths is not None:
        try:
            listing = bagdb3.topics(paths)
            std = _store(ros1=False).hash_rihs01(IMU_TYPE)
            if all(h in ("", std) for _, t, h in listing if t == IMU_TYPE):
                return Db3Backend(paths, listing)
        except ImportError:
            raise InputError(f"'{name}': reading ROS bags needs the rosbags package (pip install rosbags)") from None
        except Exception:  # sqlite's or the schema's surprises: rosbags says what is wrong
            pass
    elif McapBackend.fits(path):
        return McapBackend(path, name)
    elif os.path.isfile(path) and (ros1 := Ros1Backend.read_index(path)) is not None:
        return Ros1Backend(path, ros1)
    return RosbagsBackend(path, name)


def _pick(path: str, name: str, bag: Backend, topic: Optional[str]) -> tuple[Backend, str]:
    """The backend and topic to read: a sensor_msgs/Imu topic (``--topic``, or
    the only one), else a topic whose own message type holds one."""
    imu = sorted({t for t, m in bag.topics if m == IMU_TYPE})
    if topic is None and len(imu) > 1:
        raise InputError(f"'{name}': {len(imu)} IMU topics: choose one with --topic ({', '.join(imu)})")
    if imu and topic in (None, *imu):
        return bag, topic if topic is not None else imu[0]
    held = carriers(path, name)
    if topic is None and len(held) > 1:
        raise InputError(
            f"'{name}': {len(held)} topics hold a sensor_msgs/Imu: choose one with --topic ({', '.join(sorted(held))})"
        )
    chosen = topic if topic is not None else next(iter(held), None)
    if chosen in held:
        return CarrierBackend(path, name, *held[chosen]), chosen
    if topic is not None and (imu or held):
        found = ", ".join(imu + sorted(held))
        raise InputError(f"'{name}': --topic {topic}: no sensor_msgs/Imu messages on it (IMU topics: {found})")
    seen = ", ".join(sorted({f"{t} ({m})" for t, m in bag.topics})) or "none"
    raise InputError(f"'{name}': no sensor_msgs/Imu topic in the bag (topics: {seen})")


def bag_source(path: str, name: str, topic: Optional[str]) -> Any:
    """The SampleSource of the IMU topic of the bag at ``path``."""
    from .source import SampleSource

    bag, chosen = _pick(path, name, _backend(path, name), topic)
    try:
        bag.choose(chosen)
    except InputError:
        raise
    except Exception as exc:  # sqlite's or rosbags' errors on a damaged bag
        raise InputError(f"'{name}': not a readable ROS bag ({type(exc).__name__}: {exc})") from None
    others = sorted({t for t, _ in bag.topics} - {chosen})
    first = next(_decoded(bag, name, True, SNIFF_MESSAGES), None)
    if first is None or first[0].shape[1] < 3:
        raise InputError(
            f"'{name}': topic {chosen} holds {0 if first is None else first[0].shape[1]} messages: too few"
        )
    vals, stamps, recorded = first
    use_stamps = bool(np.all(np.diff(stamps) > 0))
    t = stamps if use_stamps else recorded
    assert t is not None
    t0 = int(t[0])
    what = f"the header stamps of {chosen}" if use_stamps else f"the times the bag recorded {chosen}"
    check = rate_from_time(name, (t - t0).astype(np.float64), 1e-9, what)
    src = SampleSource(
        "rosbag", name, list(CHANNELS), lambda: iter(()), False, fs=check.fs, n_hint=bag.count, units=dict(UNITS)
    )
    src.time, src.topic = check, chosen
    src.notes.append(check.note)
    if not use_stamps:
        src.notes.append(f"the header stamps of {chosen} do not increase (left zero?): the bag's times used")
    carrier = isinstance(bag, CarrierBackend)
    read = f"({bag.msgtype}): its field {bag.field} (sensor_msgs/Imu)" if carrier else "(sensor_msgs/Imu)"
    src.notes.append(
        f"topic {chosen} {read}: angular_velocity and linear_acceleration read in rad/s "
        "and m/s^2 (the message's units); orientation and the three covariances not used"
        + (f"; the rest of {bag.msgtype} not used" if carrier else "")
        + (f"; topics not read: {', '.join(others)}" if others else "")
    )
    if carrier and bag.outer_stamps:
        src.notes.append(
            f"the stamps of {bag.field}.header are not times (nanoseconds past a second): {chosen}'s own header used"
        )

    def blocks() -> Iterator[np.ndarray]:
        check.start()
        done = 0
        for vals, stamps, recorded in _ahead(_decoded(bag, name, not use_stamps)):
            when = stamps if use_stamps else recorded
            assert when is not None
            check.feed((when - t0).astype(np.float64))
            bad = ~np.isfinite(vals).all(axis=0)
            if bad.any():
                k = done + int(np.argmax(bad))
                raise InputError(f"'{name}': topic {chosen}, message {k + 1}: a value is not a finite number")
            done += vals.shape[1]
            yield vals
        check.finish(src.notes)

    src.open_blocks = blocks
    return src


AHEAD = 2
"""Blocks read ahead by a thread while the statistics work on the last one."""


def _ahead(blocks: Iterator[Any]) -> Iterator[Any]:
    """``blocks``, read by a thread ahead of the consumer: sqlite, the
    decompressors and numpy let go of the GIL, so reading a bag overlaps the
    statistics on a second core. Errors arrive in order, as raised."""
    q: queue.Queue = queue.Queue(maxsize=AHEAD)
    stop = threading.Event()

    def put(item: tuple[str, Any]) -> bool:
        while not stop.is_set():
            try:
                q.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def run() -> None:
        try:
            for b in blocks:
                if not put(("block", b)):
                    break
            else:
                put(("end", None))
        except BaseException as exc:  # handed to the consumer, raised there
            put(("error", exc))
        finally:
            getattr(blocks, "close", lambda: None)()

    thread = threading.Thread(target=run, name="bag-reader", daemon=True)
    thread.start()
    try:
        while True:
            kind, item = q.get()
            if kind == "end":
                return
            if kind == "error":
                raise item
            yield item
    finally:
        stop.set()
        thread.join()


def _decoded(
    bag: Backend, name: str, times: bool, limit: Optional[int] = None
) -> Iterator[tuple[np.ndarray, np.ndarray, Optional[np.ndarray]]]:
    """(6, k) values ax ay az gx gy gz, (k,) header stamps in ns, (k,) bag
    times in ns (when ``times``), block by block: arrays where a message's
    layout is the standard one and rosbags agrees on its first message,
    rosbags' deserialiser for the rest."""
    agreed: dict[int, bool] = {}
    done = 0
    try:
        for block in bag.open_raw(times, limit):
            if block.imu is not None:
                vals, stamps, odd, keys = block.imu.vals, block.imu.stamps, block.imu.odd.copy(), block.imu.keys
            else:
                vals, stamps, odd, keys = imumsg.decode(block.raw, block.lens, bag.ros1)
            start = np.cumsum(block.lens) - block.lens
            ok = keys[~odd]
            for key in ok[:1] if len(ok) and np.all(ok == ok[0]) else np.unique(ok):  # one layout: the usual bag
                if int(key) not in agreed:
                    i = int(np.flatnonzero((keys == key) & ~odd)[0])
                    agreed[int(key)] = _agrees(bag, _slice(block, start, i), vals[:, i], int(stamps[i]))
                if not agreed[int(key)]:
                    odd |= keys == key
            for i in np.flatnonzero(odd):
                m = _deserialize(bag, _slice(block, start, int(i)), name, done + int(i))
                vals[:, i], stamps[i] = _values(m), _stamp(m)
            done += len(block.lens)
            yield vals, stamps, block.times
    except InputError:
        raise
    except Exception as exc:  # sqlite's or rosbags' errors on a damaged bag
        raise InputError(f"'{name}': not a readable ROS bag ({type(exc).__name__}: {exc})") from None


def _slice(block: Raw, start: np.ndarray, i: int) -> bytes:
    if block.fetch is not None:
        return block.fetch(i)
    return bytes(block.raw[int(start[i]) : int(start[i] + block.lens[i])])


def _agrees(bag: Backend, raw: bytes, vals: np.ndarray, stamp: int) -> bool:
    """The array decoding gives what rosbags gives on this message."""
    try:
        m = bag.deserialize(raw)
    except Exception:
        return False
    return bool(np.array_equal(vals, _values(m), equal_nan=True)) and stamp == _stamp(m)


def _deserialize(bag: Backend, raw: bytes, name: str, k: int) -> Any:
    try:
        return bag.deserialize(raw)
    except Exception as exc:
        raise InputError(
            f"'{name}': message {k + 1} is not a readable sensor_msgs/Imu ({type(exc).__name__})"
        ) from None


def _values(m: Any) -> np.ndarray:
    a, w = m.linear_acceleration, m.angular_velocity
    return np.array([a.x, a.y, a.z, w.x, w.y, w.z], dtype=np.float64)


def _stamp(m: Any) -> int:
    s = m.header.stamp
    return int(s.sec) * 1_000_000_000 + int(s.nanosec)
