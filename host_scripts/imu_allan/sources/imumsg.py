"""sensor_msgs/Imu messages decoded as arrays, many at a time, without a
Python object per message.

The message's layout is fixed but for ``header.frame_id``, a string:

- ROS 1: ``seq`` uint32, stamp ``secs`` and ``nsecs``, ``frame_id`` (uint32
  length, bytes), then 37 float64 packed (orientation 4, its covariance 9,
  angular_velocity 3, covariance 9, linear_acceleration 3, covariance 9);
- ROS 2 (CDR): a 4-byte encapsulation header (``00 01``: little-endian,
  ``00 00``: big-endian), stamp ``sec`` int32 and ``nanosec`` uint32,
  ``frame_id`` (uint32 length counting its NUL, bytes, NUL), padding to 8
  bytes (counted from after the encapsulation header), the same 37 float64.

So a message's length fixes where every field lies: messages are grouped by
length (and byte order), each group read through one numpy structured dtype.
A message whose recorded string length does not give its total length (or
any other layout) is left to the caller (``odd``), to be deserialised by
rosbags: nothing is decoded from a guess. Stamps are read as rosbags reads
them (``sec`` int32 in both, as its ``builtin_interfaces/msg/Time``).

The compiled page reader of ROS 2 sqlite3 bags (``_db3pages.c``, imu_row)
reads CDR messages this same way, in C; tests/test_bag_pages_imu.py holds
the two equal on every layout.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Union

import numpy as np

DOUBLES = 37
"""float64 after the header: orientation 4+9, angular_velocity 3+9, linear_acceleration 3+9."""
GYRO_AT, ACC_AT = 13 * 8, 25 * 8  # byte offsets of angular_velocity and linear_acceleration in them
ROS1_FIXED = 16 + 8 * DOUBLES  # seq, secs, nsecs, string length, the doubles: all but the string
CDR_FIXED = 4 + 8 * DOUBLES  # the encapsulation header and the doubles; stamp+string padded to 8

Bytes = Union[bytes, bytearray, memoryview, np.ndarray]


HEAD = 16
"""Bytes before frame_id's text: CDR's header + sec + nanosec + length, or ROS 1's seq + secs + nsecs + length."""


@lru_cache(maxsize=64)
def layout(length: int, ros1: bool, big: bool, compact: bool = False) -> np.dtype:
    """The structured dtype of one message of ``length`` bytes (fields: sec,
    nsec, flen, gyro (3,), acc (3,), and enc, CDR's header); ``compact``:
    of the 64 bytes ``gather`` keeps of it."""
    e = ">" if big else "<"
    names, formats, offsets = ["sec", "nsec", "flen", "gyro", "acc"], [e + "i4", e + "u4", e + "u4"], [4, 8, 12]
    formats += [(e + "f8", 3), (e + "f8", 3)]
    offsets += [HEAD, HEAD + 24] if compact else [length - 8 * DOUBLES + GYRO_AT, length - 8 * DOUBLES + ACC_AT]
    if not ros1:
        names, formats, offsets = ["enc", *names], [">u2", *formats], [0, *offsets]
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": 64 if compact else length})


def gather(raw: np.ndarray, start: np.ndarray, length: int) -> np.ndarray:
    """(m, 64) bytes of the messages of ``length`` bytes at ``start``: the
    header up to frame_id's text, then angular_velocity, linear_acceleration."""
    d = length - 8 * DOUBLES
    cols = np.r_[0:HEAD, d + GYRO_AT : d + GYRO_AT + 24, d + ACC_AT : d + ACC_AT + 24]
    return raw[start[:, None] + cols]


def _string_fits(flen: np.ndarray, length: int, ros1: bool) -> np.ndarray:
    """Where the recorded frame_id length gives the message's total length."""
    if ros1:
        return flen == length - ROS1_FIXED
    padded = length - CDR_FIXED  # stamp (8) + length field (4) + string, rounded up to 8
    return (flen >= 1) & ((12 + flen.astype(np.int64) + 7) // 8 * 8 == padded)


def _group(rec: np.ndarray, length: int, ros1: bool, big: bool, vals: np.ndarray, stamps: np.ndarray) -> np.ndarray:
    """Values and stamps of one group's records into ``vals`` (6, m) and
    ``stamps`` (m,); returns the messages that fit the layout."""
    ok = _string_fits(rec["flen"], length, ros1)
    if not ros1:  # plain CDR in the byte order of the group (not PL_CDR, not XCDR2)
        ok &= rec["enc"] == (0 if big else 1)
    vals[:3] = rec["acc"].T
    vals[3:] = rec["gyro"].T
    stamps[:] = rec["sec"].astype(np.int64) * 1_000_000_000 + rec["nsec"]
    return ok


def decode(buf: Bytes, lens: np.ndarray, ros1: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Messages laid end to end in ``buf``, of lengths ``lens`` (a block: a
    few 1e4, as messages of several lengths take 512 bytes each here): values
    (6, k) ax ay az gx gy gz, header stamps (k,) in ns, ``odd`` (k,): the
    messages not decoded (their values and stamps are meaningless), and each
    one's layout (2 x length + 1 if big-endian), for the caller to check one
    message of each against a deserialiser."""
    raw = np.frombuffer(buf, dtype=np.uint8)
    lens = np.asarray(lens, dtype=np.int64)
    k = len(lens)
    if int(lens.sum()) != raw.size:
        raise ValueError("the lengths do not add up to the bytes")
    vals, stamps = np.zeros((6, k)), np.zeros(k, dtype=np.int64)
    odd = np.ones(k, dtype=bool)
    if k == 0:
        return vals, stamps, odd, lens
    start = np.cumsum(lens) - lens
    big = np.zeros(k, dtype=bool)
    if not ros1:  # CDR: the representation byte says the byte order (0 big, 1 little)
        whole = lens >= 4
        big[whole] = raw[start[whole] + 1] == 0
    floor = ROS1_FIXED if ros1 else CDR_FIXED + 16
    keys = lens * 2 + big
    if lens[0] >= floor and np.all(keys == keys[0]):  # the usual bag: one layout, read in place
        length, b = int(lens[0]), bool(big[0])
        odd[_group(raw.view(layout(length, ros1, b)), length, ros1, b, vals, stamps)] = False
        return vals, stamps, odd, keys
    for key in np.unique(keys):
        length, b = int(key) // 2, bool(key % 2)
        if length < floor:
            continue
        idx = np.flatnonzero(keys == key)
        rec = gather(raw, start[idx], length).reshape(-1).view(layout(length, ros1, b, compact=True))
        v, s = np.empty((6, len(idx))), np.empty(len(idx), dtype=np.int64)
        ok = _group(rec, length, ros1, b, v, s)
        vals[:, idx], stamps[idx] = v, s
        odd[idx[ok]] = False
    return vals, stamps, odd, keys


def in_time_order(
    times: list[np.ndarray], lens: list[np.ndarray], parts: list[np.ndarray]
) -> tuple[bytes, np.ndarray, np.ndarray]:
    """A chunk's messages (their bytes back to back, lengths, stamps in ns)
    joined and stably sorted by time, as rosbags orders a chunk's messages."""
    t, ln, raw = np.concatenate(times), np.concatenate(lens), np.concatenate(parts)
    if np.any(np.diff(t) < 0):
        order = np.argsort(t, kind="stable")
        start = np.cumsum(ln) - ln
        raw = np.concatenate([raw[start[i] : start[i] + ln[i]] for i in order])
        t, ln = t[order], ln[order]
    return raw.tobytes(), ln, t
