"""The decoder's second line of defence behind the CRC-16: a line whose CRC-16 still
matches after a change, and a report spliced from lines of two runs, are never
accepted as something the device did not send.

Corruptions are brute-forced: every value of a field (or of the last hex
digits of ``acc``) is tried, and the ones that keep the line's CRC are fed to
the decoder.  Line runs are deleted, duplicated and moved at random across a
log holding three runs separated by resets."""

from __future__ import annotations

import binascii
import math
import random

import numpy as np
import pytest
from conftest import CH, exact_acc, header_body, line, thesis_like

from imu_allan.device.records import decode_bytes

FS = 100


def _sig3(v: float) -> str:
    """The summary's 3 significant digits (docs/protocol.md), written out here."""
    if v < 1e-3:
        mant, exp = f"{v:.2e}".split("e")
        return f"{mant}e{int(exp)}"
    return f"{v:.0f}" if v >= 999.5 else f"{v:#.3g}".rstrip(".")


def _report(codes: np.ndarray, levels: int, seq: int, running_n: int | None = None) -> list[bytes]:
    """A whole report as the device sends it, S summary included: a stopped run
    of all ``codes``, or (``running_n``) a running one whose header said n then."""
    n = len(codes)
    head_n = n if running_n is None else running_n
    out = [line(header_body(seq, levels, head_n, FS, run=0 if running_n is None else 1))]
    adev: dict[tuple[str, int], float] = {}
    for c, ch in enumerate(CH):
        col = [int(v) for v in codes[:, c]]
        for k in range(levels):
            m = 1 << k
            pairs = max(n // m - 1, 0)
            acc = exact_acc(col, m, pairs)
            out.append(line(f"L,{seq},{ch},{k},{pairs},{acc:012X},00"))
            if pairs:
                adev[ch, k] = math.sqrt(acc / (2 * m * m * pairs))
    out.append(line(f"S,{seq},{'tau_s':>9}" + "".join(f"{ch:>9}" for ch in CH)))
    for k in range(levels):
        if (CH[0], k) in adev:
            out.append(line(f"S,{seq},{_sig3((1 << k) / FS):>9}" + "".join(f"{_sig3(adev[ch, k]):>9}" for ch in CH)))
    out.append(line(f"E,{seq},{6 * levels}"))
    return out


def _crc_keepers(prefix: bytes, variants: list[bytes], want: int) -> list[bytes]:
    """The variants whose line ``prefix + variant`` has CRC ``want``."""
    state = binascii.crc_hqx(prefix, 0xFFFF)
    return [v for v in variants if binascii.crc_hqx(v, state) == want]


def _accepted_rows(data: bytes) -> dict[int, dict[tuple[str, int], tuple[int, int, str]]]:
    out = {}
    for rep in decode_bytes(data).reports:
        out[rep.seq] = {
            (r.channel, r.level): (r.pairs, r.flags, _sig3(math.sqrt(r.avar)) if r.pairs else "-") for r in rep.rows
        }
    return out


CODES = thesis_like(3000, 5)
LEVELS = 6


@pytest.mark.parametrize("running", [False, True])
def test_crc_preserving_changes_never_give_a_wrong_number(running: bool) -> None:
    lines = _report(CODES, LEVELS, seq=3, running_n=2950 if running else None)
    truth = _accepted_rows(b"".join(lines))[3]
    rng = random.Random(1)
    tried = kept = 0
    for index in rng.sample(range(1, 1 + 6 * LEVELS), 18):  # L lines
        body = lines[index][1:-7]  # between '$' and '*CRC\r\n'
        want = int(lines[index][-6:-2], 16)
        f = body.split(b",")
        prefix = b",".join(f[:5]) + b","
        variants = []
        # acc: every value of its last 4 hex digits (65536), flags kept
        variants += [prefix + f[5][:8] + b"%04X" % v + b"," + f[6] for v in range(1 << 16)]
        # pairs and flags together: every pairs of the same width, every flags byte
        width = len(f[4])
        head = b",".join(f[:4]) + b","
        variants += [
            head + b"%0*d" % (width, p) + b"," + f[5] + b",%02X" % fl for p in range(10**width) for fl in (0, 1, 2, 3)
        ]
        # channel and level: every other row key with the acc's last 2 digits free
        variants += [
            b"L,3," + ch.encode() + b",%d," % k + f[4] + b"," + f[5][:10] + b"%02X" % v + b"," + f[6]
            for ch in CH
            for k in range(LEVELS)
            for v in range(256)
        ]
        for body2 in _crc_keepers(b"", [v for v in variants if v != body], want):
            tried += 1
            changed = list(lines)
            changed[index] = b"$" + body2 + b"*%04X\r\n" % want
            got = _accepted_rows(b"".join(changed))
            if 3 in got:
                kept += 1
                _assert_within_the_summary(got[3], truth, body2, running)
    assert tried >= 15  # the brute force found CRC-preserving changes to refuse
    print(f"running={running}: {tried} CRC-preserving changes, {kept} accepted")


def _assert_within_the_summary(got: dict, truth: dict, body: bytes, running: bool) -> None:
    """The structure (which rows, their pairs and flags) is always the truth.
    A changed acc passes only within what the summary can tell: one unit of
    its last digit in a stopped run (the device rounds in single precision);
    while the run goes on the summary is a little newer than the rows, so 25 %
    on rows with 1000 pairs or more."""
    assert got.keys() == truth.keys(), body
    for key, (pairs, flags, dev) in got.items():
        assert (pairs, flags) == truth[key][:2], body
        if dev == "-":
            continue
        want = float(truth[key][2])
        if not running:
            unit = 10.0 ** (math.floor(math.log10(want)) - 2)
            assert abs(float(dev) - want) <= 2 * unit, body  # both sides rounded to 3 digits
        elif pairs >= 1000:
            assert abs(float(dev) / want - 1) <= 0.26, body


def _log_with_resets() -> tuple[list[bytes], list[list[bytes]]]:
    """Four runs of very different length separated by resets; the reports of
    the first and third are cut off by the reset, so the next run's report
    reuses their seq (it advances only at E): a splice of two runs waiting to happen."""
    a, b, c, d = (thesis_like(n, s) for n, s in ((5010, 1), (510, 2), (2500, 3), (9000, 4)))
    boot = [line("B,proto=1,fw=0.1.0,mcu=atmega168,reset=por")]
    cut_a = _report(a, 5, seq=0)[:26] + [line("ok reset")]
    rb = _report(b, 5, seq=0)
    cut_c = _report(c, 5, seq=1, running_n=2400)[:29] + [line("ok reset rate=100")]
    rd = _report(d, 5, seq=1, running_n=8950)
    return boot + cut_a + rb + [line("ok started")] + cut_c + rd, [rb, rd]


def test_deleted_duplicated_and_spliced_line_runs_never_splice_runs() -> None:
    lines, originals = _log_with_resets()
    truth = {}
    for rep in originals:
        truth.update(_accepted_rows(b"".join(rep)))
    assert _accepted_rows(b"".join(lines)) == truth
    rng = random.Random(7)
    accepted = refused = 0
    for trial in range(400):
        mutated = list(lines)
        for _ in range(rng.randint(1, 3)):
            i = rng.randrange(len(mutated))
            j = min(len(mutated), i + rng.randint(1, 40))
            run = mutated[i:j]
            op = rng.choice(("delete", "duplicate", "move"))
            if op in ("delete", "move"):
                del mutated[i:j]
            if op in ("duplicate", "move"):
                at = rng.randrange(len(mutated) + 1)
                mutated[at:at] = run
        res = decode_bytes(b"".join(mutated))
        for rep in res.reports:
            accepted += 1
            got = _accepted_rows(b"".join(_report_lines_of(rep)))
            assert rep.seq in truth and got[rep.seq] == truth[rep.seq], (trial, rep.seq)
        refused += res.errors["inconsistent_reports"]
    assert accepted > 50 and refused >= 5  # both outcomes happened
    print(f"{trial + 1} mutated logs: {accepted} reports accepted (each an original), {refused} refused")


def test_a_report_spliced_from_two_runs_is_refused() -> None:
    """A report cut off by a reset, the reset's reply lost, and the next run's
    H and first rows lost: the rest of that run's report completes the first."""
    lines, _ = _log_with_resets()
    cut_end = 1 + 26  # boot, then the cut report's H and 25 rows
    spliced = lines[:cut_end] + lines[cut_end + 1 + 1 + 25 :]  # 'ok reset', B's H and 25 rows gone
    res = decode_bytes(b"".join(spliced))
    assert 0 not in [r.seq for r in res.reports]
    assert res.errors["inconsistent_reports"] == 1 and "pairs" in res.refused[0]


def _report_lines_of(rep) -> list[bytes]:
    """A decoded report written back as lines (to compare it through the same reader)."""
    h = rep.header
    out = [line(header_body(rep.seq, h.levels, h.n, FS, run=0 if h.running is False else 1))]
    out += [line(f"L,{rep.seq},{r.channel},{r.level},{r.pairs},{r.acc:012X},{r.flags:02X}") for r in rep.rows]
    return out + [line(f"E,{rep.seq},{len(rep.rows)}")]


def test_missing_reports_are_counted() -> None:
    reps = [_report(CODES[:500], 3, seq=s) for s in range(6)]
    data = b"".join(reps[0] + reps[1] + reps[4] + reps[5])  # seq 2 and 3 vanished whole
    res = decode_bytes(data)
    assert [r.seq for r in res.reports] == [0, 1, 4, 5] and res.errors["missing_reports"] == 2
    cut = reps[2][:5] + [line("ok reset")]  # a cut report keeps its seq: nothing missing
    res = decode_bytes(b"".join(reps[0] + reps[1] + cut + reps[2] + reps[3]))
    assert res.errors["missing_reports"] == 0 and res.errors["incomplete_reports"] == 1
    boot = [line("B,proto=1,fw=0.1.0,mcu=atmega168,reset=ext")]
    res = decode_bytes(b"".join(reps[3] + boot + reps[0]))  # seq counts from 0 after a boot
    assert res.errors["missing_reports"] == 0


def test_lower_case_hex_is_refused() -> None:
    rep = _report(CODES[:500], 3, seq=1)
    low = [rep[0]] + [ln[:-6] + ln[-6:-2].lower() + ln[-2:] for ln in rep[1:2]] + rep[2:]
    res = decode_bytes(b"".join(low))
    assert not res.reports and (res.errors["malformed"] == 1 or rep[1][-6:-2] == rep[1][-6:-2].lower())
    body = rep[1][1:-7].decode()
    lower_acc = body[:-9] + body[-9:-3].lower() + body[-3:]
    if lower_acc != body:
        res = decode_bytes(b"".join([rep[0], line(lower_acc)] + rep[2:]))
        assert not res.reports and res.errors["unparsable"] == 1
