"""The device's echo of typed lines ("> ..." CR LF, docs/protocol.md) is
neither data nor garbage for the decoders, in report logs and raw captures."""

from __future__ import annotations

from conftest import line, raw_row, report_lines, thesis_like

from imu_allan.device.records import decode_bytes
from imu_allan.device.stream import StreamDecoder

ECHO = b"> stat\b \bus\r\n"  # typed with a Backspace


def test_report_log_with_echo_lines_has_no_garbage() -> None:
    rows = thesis_like(300, 3)
    lines = report_lines(rows, 6)
    data = ECHO + line("ok status run=0") + lines[0] + b"> report\r\n" + b"".join(lines[1:])
    res = decode_bytes(data)
    assert len(res.reports) == 1 and res.replies == ["ok status run=0"]
    assert sum(res.errors.values()) == 0, res.errors


def test_raw_capture_with_echo_lines_keeps_every_row() -> None:
    rows = thesis_like(250, 4)
    data = (
        b"".join(raw_row(r) for r in rows[:120])
        + b"> status\r\n"
        + line("ok status run=1")
        + b"".join(raw_row(r) for r in rows[120:])
    )
    dec = StreamDecoder(line_start=True)  # the capture starts at a line's start
    replies = dec.feed(data).replies + dec.finish().replies
    got = dec.counts
    assert got["rows"] == 250 and got["bad_rows"] == 0 and got["garbage_bytes"] == 0, got
    assert replies == ["ok status run=1"]
