"""decode checks every line type it accepts: a T line (or the summary's terms
rows) that passed its line CRC by collision but contradicts the report's rows
is refused, counted and said; seq going backwards without a boot line is
said; CR, LF and CR LF line ends read alike; a line without end costs no
more memory than MAX_LINE."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import CH, exact_acc, line, report_lines, thesis_like

from imu_allan.device.framing import MAX_LINE, LineSplitter, split_frames
from imu_allan.device.records import decode_bytes
from imu_allan.device.stream import StreamDecoder

FS = 100
LEVELS = 15


def _terms(rows: np.ndarray, ch: str) -> tuple[int, float, int, float]:
    """N and B of a stopped run, from plain-int exact sums (docs/protocol.md, T)."""
    n = len(rows)
    codes = [int(v) for v in rows[:, CH.index(ch)]]
    adev = {}
    for k in range(LEVELS):
        m, pairs = 1 << k, max(n // (1 << k) - 1, 0)
        if pairs:
            adev[k] = (pairs, math.sqrt(exact_acc(codes, m, pairs) / (2 * m * m * pairs)))
    kn = min(adev, key=lambda k: (abs(2**k - FS), k))
    kb = min((k for k in adev if adev[k][0] >= 8), key=lambda k: (adev[k][1], k))
    return kn, adev[kn][1] * math.sqrt(2**kn / FS), kb, adev[kb][1] / 0.664


def _sig3(v: float) -> str:
    return f"{float(f'{v:.3g}'):g}"


@pytest.fixture(scope="module")
def run3000() -> tuple[np.ndarray, list[bytes], dict[str, tuple[int, float, int, float]]]:
    rows = thesis_like(3000, 11)
    return rows, report_lines(rows, LEVELS), {ch: _terms(rows, ch) for ch in CH}


def _with_t(lines: list[bytes], t: list[bytes]) -> bytes:
    return b"".join(lines[:-1] + t + lines[-1:])


def _t(ch: str, kn: int, n: str, kb: int | str, b: str, seq: int = 0) -> bytes:
    return line(f"T,{seq},{ch},{kn},{n},{kb},{b}")


def test_a_collided_t_line_beyond_the_levels_is_refused(run3000) -> None:
    rows, lines, terms = run3000
    t = [_t(ch, terms[ch][0], _sig3(terms[ch][1]), terms[ch][2], _sig3(terms[ch][3])) for ch in CH]
    ok = decode_bytes(_with_t(lines, t))
    assert ok.warnings == [] and sorted(ok.reports[0].terms) == sorted(CH)
    # gx's T line as a CRC collision could leave it: B at level 17 of a 15-level report, 0 pairs
    t[3] = _t("gx", terms["gx"][0], _sig3(terms["gx"][1]), 17, "0")
    res = decode_bytes(_with_t(lines, t))
    rep = res.reports[0]
    assert "gx" not in rep.terms and sorted(rep.terms) == ["ax", "ay", "az", "gy", "gz"]
    assert res.errors["inconsistent_lines"] == 1
    assert res.warnings == ["report seq 0: refused the T line of gx (gx B: level 17, beyond the report's 15 levels)"]
    assert rep.refused == ["T line of gx (gx B: level 17, beyond the report's 15 levels)"]


@pytest.mark.parametrize(
    "fudge, said",
    [
        (lambda kn, n, kb, b: (kn, n, 10, b), "level 10, whose row has 1 pairs (the term needs 8)"),
        (lambda kn, n, kb, b: (kn + 1, n, kb, b), "device used level"),
        (lambda kn, n, kb, b: (kn, n * 1.02, kb, b), "beyond the printed precision"),
        (lambda kn, n, kb, b: (kn, n, kb, b * 3), "beyond the printed precision"),
    ],
)
def test_a_t_line_the_rows_contradict_is_refused(run3000, fudge, said) -> None:
    _, lines, terms = run3000
    t = [_t(ch, *_fmt(fudge(*terms[ch]) if ch == "az" else terms[ch])) for ch in CH]
    res = decode_bytes(_with_t(lines, t))
    assert "az" not in res.reports[0].terms and len(res.reports[0].terms) == 5
    assert len(res.warnings) == 1 and said in res.warnings[0] and "T line of az" in res.warnings[0]


def _fmt(t: tuple[int, float, int, float]) -> tuple[int, str, int, str]:
    return t[0], _sig3(t[1]), t[2], _sig3(t[3])


@pytest.mark.parametrize("value", ["1.234", "1e3", "nan", "inf", "1_0", " 1", "-1", "0x1F", "1.2E-4"])
def test_a_t_value_not_printed_as_the_device_prints_is_unparsable(run3000, value) -> None:
    _, lines, terms = run3000
    t = [
        _t(ch, terms[ch][0], value if ch == "ay" else _sig3(terms[ch][1]), terms[ch][2], _sig3(terms[ch][3]))
        for ch in CH
    ]
    res = decode_bytes(_with_t(lines, t))
    assert "ay" not in res.reports[0].terms and res.errors["unparsable"] == 1


def test_two_t_lines_of_one_channel_are_both_refused(run3000) -> None:
    _, lines, terms = run3000
    t = [_t(ch, *_fmt(terms[ch])) for ch in CH] + [_t("gz", *_fmt(terms["gz"]))]
    res = decode_bytes(_with_t(lines, t))
    assert "gz" not in res.reports[0].terms and "two T lines" in res.warnings[0]


def test_a_running_report_takes_terms_its_rows_may_have_reached() -> None:
    """While the run goes on, T is computed a little after the rows: a level
    whose row has 7 pairs may have 8 by then (10 s of samples at most)."""
    rows = thesis_like(2000, 12)
    lines = report_lines(rows, LEVELS, header_n=1990)
    kn, n, kb, b = _terms(rows, "ax")
    grown = [_t(ch, kn, _sig3(n), 8, "1") for ch in CH]  # level 8: 6 pairs, 8 within reach
    res = decode_bytes(_with_t(lines, grown))
    assert res.warnings == [] and len(res.reports[0].terms) == 6
    far = [_t(ch, kn, _sig3(n), 11, "1") for ch in CH]  # level 11: 0 pairs, 8 need 18432 samples
    res = decode_bytes(_with_t(lines, far))
    assert res.reports[0].terms == {} and res.errors["inconsistent_lines"] == 6


def _summary_terms(terms: dict, rows: np.ndarray, seq: int = 0, b_scale: float = 1.0) -> list[bytes]:
    """The summary's terms part in counts (header without units=: counts)."""
    kn = terms["ax"][0]
    pn = len(rows) // 2**kn - 1
    out = [line(f"S,{seq},N at {_sig3(2**kn / FS)} s +-{_sig3(100 / math.sqrt(2 * pn))}%: count rt(s); B: counts")]
    cells = {
        "N": [terms[ch][1] for ch in CH],
        "B": [terms[ch][3] * b_scale for ch in CH],
        "+-%": [100 / math.sqrt(2 * (len(rows) // 2 ** terms[ch][2] - 1)) for ch in CH],
        "tau_s": [2 ** terms[ch][2] / FS for ch in CH],
    }
    for name, vals in cells.items():
        out.append(line(f"S,{seq}," + f"{name:>9}" + "".join(f"{_sig3(v):>9}" for v in vals)))
    return out


def test_the_summary_terms_rows_are_checked_by_decode(run3000) -> None:
    rows, lines, terms = run3000
    t = [_t(ch, *_fmt(terms[ch])) for ch in CH]
    good = decode_bytes(_with_t(lines, t + _summary_terms(terms, rows)))
    assert good.warnings == [] and any(s.startswith("N at ") for s in good.reports[0].summary)
    bad = decode_bytes(_with_t(lines, t + _summary_terms(terms, rows, b_scale=1.5)))
    rep = bad.reports[0]
    assert len(rep.terms) == 6 and bad.errors["inconsistent_lines"] == 1
    assert "refused the summary's terms rows (ax B: summary shows" in bad.warnings[0]
    assert not any(s.startswith("N at ") for s in rep.summary)  # never presented
    assert rep.summary[1].split()[0] == "tau_s"  # the column heading stays


def test_check_lists_what_decode_refused(tmp_path: Path, run3000, run_cli) -> None:
    from conftest import write_rows

    rows, lines, terms = run3000
    t = [_t(ch, *_fmt(terms[ch])) for ch in CH]
    t[0] = _t("ax", terms["ax"][0], _sig3(terms["ax"][1]), 17, "0")
    log = tmp_path / "dev.log"
    log.write_bytes(_with_t(lines, t))
    rc, out, err = run_cli("check", log, write_rows(tmp_path / "rows.txt", rows))
    assert rc == 1 and "refused by decode: the T line of ax" in out
    assert err.startswith("imu-allan check: warning: report seq 0: refused the T line of ax")


def test_seq_going_backwards_without_a_boot_line_is_said(tmp_path: Path, run_cli) -> None:
    rows = thesis_like(40, 13)
    older, newer = report_lines(rows, 3, seq=3), report_lines(rows, 3, seq=7)
    boot = line("B,proto=1,fw=0.1.0,mcu=atmega168,reset=por")
    res = decode_bytes(b"".join(newer + older))  # seq 3 replayed after seq 7
    assert [r.seq for r in res.reports] == [7, 3] and res.errors["seq_backwards"] == 1
    assert res.warnings[0].startswith("report seq 3 comes after seq 7 without a boot line")
    assert decode_bytes(b"".join(newer + [boot] + older)).errors["seq_backwards"] == 0
    wrap = decode_bytes(b"".join(report_lines(rows, 3, seq=65535) + report_lines(rows, 3, seq=0)))
    assert wrap.errors["seq_backwards"] == 0 and wrap.warnings == []
    log = tmp_path / "dev.log"
    log.write_bytes(b"".join(newer + older))
    rc, out, err = run_cli("decode", "--json", log)
    doc = json.loads(out)
    assert rc == 0 and doc["header"]["seq"] == 3 and doc["errors"]["seq_backwards"] == 1
    assert doc["warnings"] == res.warnings and "warning: report seq 3 comes after seq 7" in err
    from imu_allan.render.screen import Monitor

    mon = Monitor("port", 115200, str(tmp_path / "m.log"))  # the monitor's decoder says it too
    mon.decoder.feed(b"".join(newer + older))
    assert mon.decoder.counts["seq_backwards"] == 1
    assert "seq_backwards 1; warning: report seq 3 comes after seq 7" in mon.errors_line()


@pytest.mark.parametrize("end", [b"\n", b"\r", b"\r\n"])
def test_every_line_end_reads_alike(end: bytes, run3000) -> None:
    _, lines, terms = run3000
    data = _with_t(lines, [_t(ch, *_fmt(terms[ch])) for ch in CH]).replace(b"\r\n", end)
    want = decode_bytes(_with_t(lines, [_t(ch, *_fmt(terms[ch])) for ch in CH]))
    got = decode_bytes(data)
    assert got.errors == want.errors and not any(got.errors.values())
    assert got.reports[0].rows == want.reports[0].rows and got.reports[0].terms == want.reports[0].terms
    # fed in pieces of 1 to 7 bytes: a CR LF cut in two still reads as one line end
    splitter, bodies, at, step = LineSplitter(), [], 0, 1
    while at < len(data):
        bodies += splitter.feed(data[at : at + step])
        at, step = at + step, step % 7 + 1
    bodies += splitter.finish()
    assert bodies == split_frames(want_data := data).bodies and len(bodies) == len(lines) + 6
    assert splitter.errors == split_frames(want_data).errors


def test_a_cr_only_capture_of_raw_rows_verifies_its_blocks() -> None:
    from imu_allan.device.framing import crc16_modbus

    codes = thesis_like(200, 14)
    raw = [("\t".join(str(int(v)) for v in r) + "\r\n").encode() for r in codes]
    counts = [line(f"C,{k},0,{crc16_modbus(b''.join(raw[k - 100 : k])):04X}") for k in (100, 200)]
    data = line("ok mode=raw") + b"".join(raw[:100]) + counts[0] + b"".join(raw[100:]) + counts[1]
    for text in (data, data.replace(b"\r\n", b"\r")):
        dec = StreamDecoder(line_start=True, verified_only=True)
        got = [dec.feed(text[i : i + 333]).samples for i in range(0, len(text), 333)]
        got.append(dec.finish().samples)
        assert np.concatenate(got, axis=1).T.tolist() == codes.tolist()
        assert dec.counts["blocks_verified"] == 2 and dec.counts["blocks_bad"] == 0


def test_a_line_without_end_is_dropped_at_max_line() -> None:
    splitter = LineSplitter()
    for _ in range(40):  # 10 M bytes of '$' restarts, never an end of line
        assert splitter.feed(b"$" * 250_000) == []
        assert len(splitter._carry) <= MAX_LINE
    assert splitter.feed(line("ok")) == ["ok"]  # the next line after it reads
    splitter.finish()
    assert splitter.errors["restarted"] == 10_000_000 and splitter.errors["malformed"] == 0
    garbage = LineSplitter()
    garbage.feed(b"x" * (3 * MAX_LINE) + b"$E,1,6")
    assert len(garbage._carry) <= MAX_LINE and garbage.errors["garbage_bytes"] == 3 * MAX_LINE
    garbage.feed(b"y" * MAX_LINE)  # the open line grows beyond MAX_LINE: dropped, counted
    assert garbage._carry == b"" and garbage.errors["malformed"] == 1


def test_the_console_firmware_rx_counters_are_read_and_older_headers_still(tmp_path: Path, run_cli) -> None:
    rows = thesis_like(40, 15)
    new, old = tmp_path / "new.log", tmp_path / "old.log"
    new.write_bytes(b"".join(report_lines(rows, 3, extra=",rx=1:2:3:65535")))
    old.write_bytes(b"".join(report_lines(rows, 3)))
    rc, out, _ = run_cli("decode", new)
    assert (
        rc == 0
        and (
            "link since power-up: 1 UART overruns, 2 bytes lost to the full receive ring, "
            "3 command lines refused (error:5), 65535 timed out (error:7)"
        )
        in out
    )
    rc, doc, _ = run_cli("decode", "--json", new)
    assert json.loads(doc)["header"]["extra"] == {"rx": "1:2:3:65535"}
    rc, out, _ = run_cli("decode", old)
    assert rc == 0 and "link since power-up" not in out and "rx=" not in out
