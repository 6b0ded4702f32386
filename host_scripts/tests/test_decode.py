"""Decoding device logs: hand-written lines, corruption, the JSON contract."""

from __future__ import annotations

import json
import math
from pathlib import Path

from conftest import CH, header_body, line, report_lines, thesis_like
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from imu_allan.device.records import decode_bytes

ROW_KEYS = {"channel", "level", "m", "tau_s", "pairs", "covers", "acc", "avar", "adev", "flags"}


def hand_report(seq: int = 5) -> list[bytes]:
    """levels=2: 12 rows with values picked by hand (as a running device could send them)."""
    out = [line(header_body(seq, 2, 1000, fs=200, run=1))]
    for c, ch in enumerate(CH):
        out.append(line(f"L,{seq},{ch},0,999,{1000 * (c + 1):012X},00"))
        out.append(
            line(
                f"L,{seq},{ch},1,499,"
                f"{0xFFFFFFFFFFFF if ch == 'gy' else 4000 * (c + 1):012X},{'03' if ch == 'gy' else '00'}"
            )
        )
    out.append(line(f"S,{seq},   tau_s       ax       ay       az       gx       gy       gz"))
    out.append(line(f"E,{seq},12"))
    return out


def test_hand_written_report_json(tmp_path: Path, run_cli) -> None:
    log = tmp_path / "dev.log"
    log.write_bytes(line("B,proto=1,fw=0.1.0,mcu=atmega168,reset=por") + line("ok started") + b"".join(hand_report()))
    rc, out, err = run_cli("decode", log, "--json")
    assert rc == 0, err
    doc = json.loads(out)
    h = doc["header"]
    assert h["version"] == 1 and h["fw"] == "0.1.0" and h["mcu"] == "atmega168"
    assert h["fcpu_hz"] == 10_000_000 and h["baud"] == 115200 and h["fs_hz"] == 200
    assert h["levels"] == 2 and h["n"] == 1000 and h["drops"] == 0 and h["seq"] == 5
    assert h["clips"] == {"ax": 0, "ay": 1, "az": 2, "gx": 3, "gy": 4, "gz": 5, "temp": 6}
    assert h["temp"] == {"mean": 63.2, "min": 50, "max": 68}
    assert h["running"] is True and h["reset_cause"] == ["por", "ext"]
    assert h["mode"] is None and h["range_g"] is None and h["cfg"] is None and h["extra"] == {}
    assert all(v == 0 for v in doc["errors"].values())
    rows = doc["rows"]
    assert [(r["channel"], r["level"]) for r in rows] == [(ch, k) for ch in CH for k in (0, 1)]
    ax0 = rows[0]
    assert set(ax0) == ROW_KEYS
    assert ax0["m"] == 1 and ax0["tau_s"] == 1 / 200 and ax0["pairs"] == 999
    assert ax0["acc"] == 1000 and ax0["covers"] == 1000 and ax0["flags"] == []
    assert ax0["avar"] == 1000 / (2 * 999) and ax0["adev"] == math.sqrt(1000 / (2 * 999))
    gy1 = rows[9]
    assert gy1["channel"] == "gy" and gy1["flags"] == ["sat", "range"]
    assert gy1["acc"] == 2**48 - 1 and gy1["avar"] == (2**48 - 1) / (2 * 4 * 499)
    gz1 = rows[11]
    assert gz1["pairs"] == 499 and gz1["acc"] == 24000 and gz1["avar"] == 24000 / (2 * 4 * 499)


def test_a_level_without_pairs(tmp_path: Path, run_cli) -> None:
    """A stopped run of 3 samples: level 1 (m = 2) has one cluster, no pair."""
    log = tmp_path / "dev.log"
    log.write_bytes(
        line(header_body(4, 2, 3, fs=200, run=0))
        + b"".join(
            line(f"L,4,{ch},0,2,{2 * (c + 1):012X},00") + line(f"L,4,{ch},1,0,{0:012X},00") for c, ch in enumerate(CH)
        )
        + line("E,4,12")
    )
    rc, out, err = run_cli("decode", log, "--json")
    assert rc == 0, err
    gz1 = json.loads(out)["rows"][11]
    assert gz1["pairs"] == 0 and gz1["avar"] is None and gz1["adev"] is None
    rc, out, _ = run_cli("decode", log, "--csv")
    assert out.splitlines()[-1] == "gz,1,2,0.01,0,2,0,,,"


def test_settings_keys_and_replies(tmp_path: Path, run_cli) -> None:
    rep = hand_report()
    rep[0] = line(header_body(5, 2, 1000, fs=200, run=1, extra=",mode=both,range=1.5,cfg=saved,new=1"))
    log = tmp_path / "dev.log"
    log.write_bytes(line("ok mode=both") + line("C,100,0") + b"".join(rep) + line("error:4 link too slow"))
    res = decode_bytes(log.read_bytes())
    h = res.reports[0].header
    assert (h.mode, h.range_g, h.cfg, h.extra) == ("both", "1.5", "saved", {"new": "1"})
    assert res.replies == ["ok mode=both", "error:4 link too slow"]
    assert res.errors["unknown_records"] == 0  # count lines are known records
    rc, out, _ = run_cli("decode", log)
    assert rc == 0 and "mode both, range 1.5 g, settings saved" in out


def test_text_and_csv(tmp_path: Path, run_cli) -> None:
    log = tmp_path / "dev.log"
    log.write_bytes(b"".join(hand_report()))
    rc, out, _ = run_cli("decode", log)
    assert rc == 0
    assert "fs 200 Hz" in out and "reset por+ext" in out and "sat range" in out
    assert "not used: nothing" in out
    rc, out, _ = run_cli("decode", log, "--csv")
    lines = out.splitlines()
    assert lines[0] == "channel,level,m,tau_s,pairs,covers,acc,avar,adev,flags"
    assert len(lines) == 13 and lines[1].startswith("ax,0,1,0.005,999,1000,1000,")
    assert lines[-1].startswith("gz,1,2,0.01,499,1000,24000,")


def test_last_and_all_reports(tmp_path: Path, run_cli) -> None:
    log = tmp_path / "dev.log"
    log.write_bytes(b"".join(hand_report(1) + hand_report(2)[:-3] + hand_report(3)))
    rc, out, _ = run_cli("decode", log, "--json")
    doc = json.loads(out)
    assert doc["header"]["seq"] == 3 and doc["complete_reports"] == 2
    assert doc["errors"]["incomplete_reports"] == 1
    rc, out, _ = run_cli("decode", log, "--json", "--all")
    doc = json.loads(out)
    assert [r["header"]["seq"] for r in doc["reports"]] == [1, 3]


def test_no_complete_report_exits_1(tmp_path: Path, run_cli) -> None:
    log = tmp_path / "dev.log"
    log.write_bytes(b"".join(hand_report()[:-1]) + b"garbage")
    rc, out, err = run_cli("decode", log)
    assert rc == 1 and out == "" and len(err.strip().splitlines()) == 1
    assert "no complete report" in err and "incomplete_reports 1" in err


def test_stdin(monkeypatch, run_cli) -> None:
    import io
    import sys

    data = b"".join(hand_report())
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(data)))
    rc, out, _ = run_cli("decode", "-", "--json")
    assert rc == 0 and json.loads(out)["header"]["seq"] == 5


def _decode(lines: list[bytes]):
    return decode_bytes(b"".join(lines))


def test_each_loss_spoils_its_report() -> None:
    base = hand_report()
    assert len(_decode(base).reports) == 1

    flipped = list(base)
    flipped[3] = flipped[3].replace(b"L,5,ay", b"L,5,az")  # CRC no longer matches
    res = _decode(flipped)
    assert not res.reports and res.errors["bad_crc"] == 1 and res.errors["incomplete_reports"] == 1

    dropped = base[:4] + base[5:]  # a lost L row: E's count no longer matches
    res = _decode(dropped)
    assert not res.reports and res.errors["incomplete_reports"] == 1

    cut = list(base)
    cut[6] = cut[6][:12] + cut[7]  # the rest of a line lost, then a '$'
    del cut[7]
    res = _decode(cut)
    assert not res.reports and res.errors["restarted"] == 1

    unparsable = list(base)
    unparsable[2] = line("L,5,ax,1,499,XYZ,00")  # CRC valid, body not
    res = _decode(unparsable)
    assert not res.reports and res.errors["unparsable"] == 1

    no_header = base[1:]
    res = _decode(no_header)
    assert not res.reports and res.errors["orphan_lines"] == 14

    reset = base[:5] + [line("B,proto=1,fw=0.1.0,mcu=atmega168,reset=wdt")] + base[5:]
    res = _decode(reset)
    assert not res.reports and res.errors["incomplete_reports"] >= 1

    wrong_proto = [line(header_body(5, 2, 1000).replace("proto=1", "proto=2"))] + base[1:]
    assert not _decode(wrong_proto).reports

    truncated = b"".join(base)[:-3]  # E line cut by the end of the log
    res = decode_bytes(truncated)
    assert not res.reports and res.errors["truncated"] == 1


def test_tolerated_noise_keeps_the_report() -> None:
    base = hand_report()
    noisy = (
        [b"\x00\xffboot garbage\r\n", line("xyz,1")]
        + base[:3]
        + [line("ok"), b"zz\n"]
        + base[3:-2]
        + [line("error:2 bad argument")]
        + base[-2:]
    )
    res = _decode(noisy)
    assert len(res.reports) == 1
    assert res.errors["unknown_records"] == 1 and res.errors["garbage_bytes"] == 16
    assert res.errors["bad_crc"] == res.errors["incomplete_reports"] == 0
    # S lines are informative: losing one does not matter
    assert len(_decode(base[:-2] + base[-1:]).reports) == 1


# ---- random corruption never yields a wrong number --------------------------------

_ROWS = thesis_like(300, 11)
_LOG = b"".join(report_lines(_ROWS[:200], 4, seq=7) + report_lines(_ROWS, 4, seq=8))
_TRUTH = {(rep.seq, r.channel, r.level): r for rep in decode_bytes(_LOG).reports for r in rep.rows}
_HEADERS = {rep.seq: rep.header for rep in decode_bytes(_LOG).reports}

_op = st.one_of(
    st.tuples(st.just("flip"), st.integers(0, len(_LOG) - 1), st.integers(1, 255)),
    st.tuples(st.just("drop"), st.integers(0, len(_LOG) - 1), st.integers(1, 40)),
    st.tuples(st.just("insert"), st.integers(0, len(_LOG)), st.binary(min_size=1, max_size=20)),
    st.tuples(st.just("dollar"), st.integers(0, len(_LOG)), st.just(b"$")),
    st.tuples(st.just("truncate"), st.integers(0, len(_LOG)), st.just(0)),
)


def _corrupt(data: bytes, ops) -> bytes:
    buf = bytearray(data)
    for kind, pos, arg in ops:
        pos = min(pos, len(buf))
        if kind == "flip" and pos < len(buf):
            buf[pos] ^= arg
        elif kind == "drop":
            del buf[pos : pos + arg]
        elif kind in ("insert", "dollar"):
            buf[pos:pos] = arg
        elif kind == "truncate":
            del buf[pos:]
    return bytes(buf)


def test_truth_is_what_was_encoded() -> None:
    assert len(_TRUTH) == 2 * 6 * 4
    assert _TRUTH[(8, "gx", 0)].pairs == 299


@settings(max_examples=300, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(_op, min_size=1, max_size=4))
def test_random_corruption_never_yields_a_wrong_row(ops) -> None:
    res = decode_bytes(_corrupt(_LOG, ops))
    for rep in res.reports:
        assert rep.header == _HEADERS[rep.seq]
        assert len(rep.rows) == 24
        for r in rep.rows:
            assert r == _TRUTH[(rep.seq, r.channel, r.level)]
    if len(res.reports) < 2 and not any(op[0] == "truncate" for op in ops):
        lost = sum(v for k, v in res.errors.items() if k != "unknown_records")
        assert lost > 0  # whatever spoiled a report was counted
