"""Mixed captures: raw rows, count lines, binary frames, reports and replies,
encoded here from the tables of docs/protocol.md (conftest), not by the package."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import bin_frame, line, random_codes, raw_row, report_lines, thesis_like
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from imu_allan.device.capture import decode_stream
from imu_allan.device.framing import encode_frame
from imu_allan.device.records import decode_bytes
from imu_allan.device.stream import StreamDecoder

BOOT = line("B,proto=1,fw=0.2.0,mcu=atmega168,reset=por")


def raw_capture(codes: np.ndarray, every: int = 100, start: int = 0) -> list[bytes]:
    """Units of a raw-mode capture: rows, and ``$C,<rows>`` after every 100th."""
    units = []
    for i, r in enumerate(codes):
        units.append(raw_row(r))
        if (start + i + 1) % every == 0:
            units.append(line(f"C,{start + i + 1}"))
    return units


def bin_capture(codes: np.ndarray, seq0: int = 0) -> list[bytes]:
    return [bin_frame((seq0 + i) % 256, r) for i, r in enumerate(codes)]


def test_package_encoder_matches_the_table() -> None:
    codes = random_codes(50, 1)
    assert all(encode_frame(i, r) == bin_frame(i, r) for i, r in enumerate(codes))
    assert bin_frame(0, [0x3FF, 0, 0, 0, 0, 0, 0x101])[9:11] == bytes([0x03, 0x10])


def test_raw_capture_gives_every_row() -> None:
    codes = random_codes(1000, 2)
    res = decode_stream(BOOT + line("ok mode=raw") + b"".join(raw_capture(codes)))
    assert res.samples.T.tolist() == codes.tolist() and not res.from_frame.any()
    c = res.counts
    assert c["rows"] == 1000 and c["count_lines"] == 10
    assert c["rows_lost"] == c["bad_rows"] == c["garbage_bytes"] == 0
    assert res.replies == ["ok mode=raw"]


def test_binary_capture_gives_every_frame() -> None:
    codes = random_codes(700, 3)  # seq wraps twice; frames hold '$', CR, LF, 0xA5 bytes
    data = bin_capture(codes[:300]) + [line("ok status run=1")] + bin_capture(codes[300:], 300)
    blob = b"".join(data)
    assert all(ch in blob for ch in (b"$", b"\r", b"\n"))
    res = decode_stream(blob)
    assert res.samples.T.tolist() == codes.tolist() and res.from_frame.all()
    assert res.replies == ["ok status run=1"]
    assert res.counts["frames"] == 700 and res.counts["frames_lost"] == 0
    assert res.counts["bad_frames"] == 0 and res.counts["malformed"] == 0


def test_frames_may_cut_into_a_text_line() -> None:
    codes = random_codes(4, 4)
    reply = line("ok status run=1 mode=binary")
    data = (
        bin_frame(0, codes[0])
        + reply[:7]
        + bin_frame(1, codes[1])
        + bin_frame(2, codes[2])
        + reply[7:]
        + bin_frame(3, codes[3])
    )
    res = decode_stream(data)
    assert res.samples.T.tolist() == codes.tolist()
    assert res.replies == ["ok status run=1 mode=binary"] and res.counts["frames_lost"] == 0


@pytest.mark.parametrize("size", [1, 5, 13, 64, 4096])
def test_pieces_of_any_size_give_the_same_result(size: int) -> None:
    codes = random_codes(600, 5)
    rows = thesis_like(64, 6)
    data = b"".join(
        [b"\x01\xa5junk", BOOT, line("ok mode=both")]
        + raw_capture(codes[:300])
        + report_lines(rows, 3, seq=1)
        + [line("ok mode=binary")]
        + bin_capture(codes[300:])
        + [b"\xa5\x01"]
    )
    whole = decode_stream(data)
    dec = StreamDecoder()
    got, reports, replies = [], [], []
    for i in range(0, len(data), size):
        ch = dec.feed(data[i : i + size])
        got.append(ch.samples)
        reports += ch.reports
        replies += ch.replies
    ch = dec.finish()
    got.append(ch.samples)
    assert np.array_equal(np.concatenate(got, axis=1), whole.samples)
    assert whole.samples.T.tolist() == codes.tolist()
    assert dec.counts == whole.counts and replies == whole.replies == ["ok mode=both", "ok mode=binary"]
    assert [r.rows for r in reports] == [r.rows for r in whole.reports]
    assert whole.reports[0].rows == decode_bytes(b"".join(report_lines(rows, 3, seq=1))).reports[0].rows
    assert whole.counts["truncated"] == 1  # the frame cut by the end
    assert whole.counts["garbage_bytes"] == 6 and whole.counts["bad_frames"] == 1


def test_bad_rows_are_counted_and_skipped() -> None:
    good = random_codes(5, 7)
    bad = [
        b"1\t2\t3\t4\t5\t6\r\n",
        b"1\t2\t3\t4\t5\t6\t7\t8\r\n",
        b"1\t2\t3\t4\t5\t6\t1024\r\n",
        b"1\t2\t3\t4\t5\t6\t00001\r\n",
        b"1 2 3 4 5 6 7\r\n",
        b"1\t2\t3\tx\t5\t6\t7\r\n",
        b"1\t2\t3\t4\t5\t6\t7\x00\r\n",
        b"\t1\t2\t3\t4\t5\t6\r\n",
        b"1\t\t2\t3\t4\t5\t6\r\n",
    ]
    data = b"\r\n" + b"".join(raw_row(good[0]) + b + raw_row(good[i % 4 + 1]) for i, b in enumerate(bad))
    res = decode_stream(data + b"\r\n\n")  # empty lines are not rows, nor bad ones
    assert res.counts["bad_rows"] == len(bad) and res.counts["rows"] == 2 * len(bad)
    assert all(r in good.tolist() for r in res.samples.T.tolist())


def test_first_line_and_cut_rows_are_never_used() -> None:
    codes = random_codes(3, 8)
    row = raw_row(codes[0])
    res = decode_stream(row[3:] + raw_row(codes[1]) + row[:-4] + line("C,5") + raw_row(codes[2]) + row[:5])
    assert res.samples.T.tolist() == codes[1:].tolist()
    assert res.counts["truncated"] == 1 and res.counts["bad_rows"] == 0
    assert decode_stream(row, line_start=True).samples.T.tolist() == [codes[0].tolist()]


@settings(max_examples=60, derandomize=True, deadline=None)
@given(st.sets(st.integers(0, 999), max_size=200))
def test_dropped_rows_are_counted(dropped: set[int]) -> None:
    codes = random_codes(1000, 9)
    out, i = [], 0
    for u in raw_capture(codes):  # drop rows by index, keep the count lines
        if u.startswith(b"$"):
            out.append(u)
        else:
            if i not in dropped:
                out.append(u)
            i += 1
    res = decode_stream(BOOT + b"".join(out))
    # rows before the first count line (rows 0..99) cannot be checked
    assert res.counts["rows_lost"] == len([d for d in dropped if d >= 100])
    assert res.counts["rows"] == 1000 - len(dropped) and res.counts["count_unchecked"] == 0


@settings(max_examples=60, derandomize=True, deadline=None)
@given(st.sets(st.integers(0, 599), max_size=250))
def test_dropped_frames_are_counted(dropped: set[int]) -> None:
    codes = random_codes(600, 10)
    frames = bin_capture(codes)
    res = decode_stream(b"".join(f for i, f in enumerate(frames) if i not in dropped))
    kept = [i for i in range(600) if i not in dropped]
    inner = [d for d in dropped if kept and kept[0] < d < kept[-1]]
    assert res.counts["frames_lost"] == len(inner)
    assert res.samples.T.tolist() == codes[kept].tolist()


def test_binary_count_lines_count_frames_and_restarts_are_not_losses() -> None:
    codes = random_codes(900, 11)
    units = []
    for i, r in enumerate(codes[:450]):  # the firmware's binary mode: count lines too
        units.append(bin_frame(i, r))
        if (i + 1) % 100 == 0:
            units.append(line(f"C,{i + 1},0"))
    units.append(line("ok reset"))  # a new run: count and sequence restart
    units += raw_capture(codes[450:], start=0)
    res = decode_stream(b"".join(units))
    c = res.counts
    assert c["rows_lost"] == c["frames_lost"] == 0 and c["count_lines"] == 8
    assert c["count_unchecked"] == 1 and res.samples.shape[1] == 900
    del units[150]  # frame 148
    del units[40]  # frame 40
    c = decode_stream(b"".join(units)).counts
    assert c["frames_lost"] == 2 and c["rows_lost"] == 1  # frame 40 precedes the first count line


def test_count_going_down_is_a_restart() -> None:
    codes = random_codes(300, 12)
    units = raw_capture(codes[:200]) + raw_capture(codes[200:])  # the reply was lost
    c = decode_stream(b"".join(units)).counts
    assert c["rows_lost"] == 0 and c["count_unchecked"] == 1


# ---- random corruption never yields a wrong sample --------------------------------


def _mixed() -> tuple[list[tuple[str, bytes]], list[list[int]], object]:
    """A capture going through modes both and binary: units tagged 'row', 'frame'
    or 'text' (a framed line, or the pieces of one cut by a frame)."""
    codes = random_codes(400, 13)
    rows = thesis_like(40, 14)
    units: list[tuple[str, bytes]] = [("text", BOOT), ("text", line("ok mode=both"))]
    for u in raw_capture(codes[:230]):
        units.append(("text" if u.startswith(b"$") else "row", u))
        if u == line("C,100"):
            units += [("text", u) for u in report_lines(rows, 3, seq=4)]
    units.append(("text", line("ok mode=binary")))
    reply = line("ok status run=1 n=400")
    for i, r in enumerate(codes[230:]):
        units.append(("frame", bin_frame(i, r)))
        if i == 50:
            units += [("text", reply[:9]), ("frame", bin_frame(i + 1, codes[231 + i])), ("text", reply[9:])]
    del units[[i for i, u in enumerate(units) if u == ("text", reply[9:])][0] + 1]  # sent above
    units.append(("text", line("ok")))
    truth = decode_bytes(b"".join(report_lines(rows, 3, seq=4))).reports[0]
    return units, codes.tolist(), truth


_UNITS, _CODES, _REPORT = _mixed()
_CHECKED = [i for i, (k, _) in enumerate(_UNITS) if k != "row"]
_NO_TAB = st.binary(min_size=1, max_size=12).filter(lambda b: b"\t" not in b)
_NOISE = (
    st.binary(min_size=1, max_size=12)
    .map(lambda b: bytes(x for x in b if not (0x30 <= x <= 0x39 or x in (9, 10))))
    .filter(bool)
)

_op = st.one_of(
    st.tuples(st.just("flip"), st.sampled_from(_CHECKED), st.integers(0, 40), st.integers(1, 255)),
    st.tuples(st.just("cut"), st.sampled_from(_CHECKED), st.integers(0, 40), st.integers(1, 30)),
    st.tuples(st.just("insert"), st.sampled_from(_CHECKED), st.integers(0, 40), _NO_TAB),
    st.tuples(st.just("noise"), st.integers(0, len(_UNITS) - 1), st.integers(0, 40), _NOISE),
    st.tuples(st.just("dollar"), st.integers(0, len(_UNITS) - 1), st.integers(0, 40), st.sampled_from([b"$", b"\xa5"])),
    st.tuples(st.just("drop"), st.integers(0, len(_UNITS) - 1), st.just(0), st.just(0)),
)


def _corrupt(ops, truncate_at) -> bytes:
    """Raw rows carry no checksum, so they are only dropped whole or broken by
    bytes that cannot belong to a row (no digit, tab or LF); frames and text
    lines take any damage (no tab inserted: no row can be made up)."""
    units = [bytearray(u) for _, u in _UNITS]
    for kind, i, pos, arg in ops:
        u = units[i]
        pos = min(pos, len(u))
        if kind == "flip" and pos < len(u):
            u[pos] ^= arg
        elif kind == "cut":
            del u[pos : pos + arg]
        elif kind in ("insert", "noise", "dollar"):
            u[pos:pos] = arg
        elif kind == "drop":
            u.clear()
    data = b"".join(units)
    return data[:truncate_at] if truncate_at is not None else data


def _is_subsequence(got: list[list[int]], ref: list[list[int]]) -> bool:
    it = iter(ref)
    return all(any(g == r for r in it) for g in got)


def test_mixed_capture_decodes_whole() -> None:
    res = decode_stream(_corrupt([], None))
    assert res.samples.T.tolist() == _CODES
    assert [r.rows for r in res.reports] == [_REPORT.rows]
    assert all(
        v == 0
        for k, v in res.counts.items()
        if k not in ("rows", "frames", "count_lines", "count_lines_nocrc", "rows_unverified")
    )


@settings(max_examples=250, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(_op, min_size=1, max_size=5), st.one_of(st.none(), st.integers(0, sum(len(u) for _, u in _UNITS))))
def test_random_corruption_never_yields_a_wrong_sample(ops, truncate_at) -> None:
    data = _corrupt(ops, truncate_at)
    res = decode_stream(data)
    got = res.samples.T.tolist()
    assert _is_subsequence(got, _CODES)
    for rep in res.reports:
        assert rep.seq == 4 and rep.rows == _REPORT.rows
    assert set(res.replies) <= {"ok mode=both", "ok mode=binary", "ok status run=1 n=400", "ok"}
    dec = StreamDecoder()  # in pieces: the same
    pieces = [dec.feed(data[i : i + 97]).samples for i in range(0, len(data), 97)]
    pieces.append(dec.finish().samples)
    assert np.concatenate(pieces, axis=1).T.tolist() == got


def test_frames_do_not_wait_behind_garbage() -> None:
    """Pure binary mode has no line ends: frames after stray text still come out
    as they arrive, and a '$' line that never ends holds them back only briefly."""
    codes = random_codes(300, 15)
    dec = StreamDecoder()
    got = dec.feed(b"zz" + b"".join(bin_capture(codes[:100]))).samples.shape[1]
    assert got == 100
    got += dec.feed(b"$ok sta" + b"".join(bin_capture(codes[100:], 100))).samples.shape[1]
    assert got == 300 and dec.counts["malformed"] == 1 and dec.counts["frames_lost"] == 0
