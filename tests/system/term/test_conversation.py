"""A person at a serial terminal, through the real pty of
`imu-sim --pty` with pyserial: the first command after the port opens,
echo and line editing, error texts, help, and the summary screen."""

from __future__ import annotations

import re
import time
from pathlib import Path

from test_sim_term import LINE, SimTerm, built, crc16  # noqa: F401  (built: the fixture)

# ---- the terminal conversation -------------------------------------------


def _until_quiet(t: SimTerm, quiet_s: float = 0.4) -> bytes:
    """Everything the device sends until it is quiet for quiet_s."""
    assert t.ser is not None
    got = b""
    quiet = time.monotonic() + quiet_s
    while time.monotonic() < quiet:
        data = t.ser.read(max(1, t.ser.in_waiting))
        if data:
            got += data
            quiet = time.monotonic() + quiet_s
    return got


def test_first_command_after_the_port_opens_is_answered(tmp_path: Path) -> None:
    """The command goes out the moment the port opens, while the device is
    still powering up: it is answered, and no byte was lost."""
    t = SimTerm(tmp_path, "--synthetic")
    try:
        t.open()
        t.send(b"status\r")
        assert t.reply(8.0).startswith("ok status run=1 ")
        assert [e for e in t.echoes if e.startswith(b"> status")]
    finally:
        assert t.stop() == 0
    assert "lost" not in t.errors()


def test_typed_text_is_echoed_and_edited(tmp_path: Path) -> None:
    t = SimTerm(tmp_path, "--synthetic")
    try:
        t.open()
        assert t.line().startswith(b"B,")
        t.send(b"stat")
        assert _until_quiet(t) == b"> stat"
        # `statsu` Backspace Backspace `us`: the device runs `status`
        t.send(b"su\x08\x7fus\r")
        got = _until_quiet(t)
        assert got.startswith(b"su\b \b\b \bus\r\n$ok status run=1 ")
        # Ctrl-C and Esc drop the line: nothing runs, the echo line ends
        # marked ^C, so that the dropped line does not look sent
        t.send(b"stop\x03")
        assert _until_quiet(t) == b"> stop^C\r\n"
        t.send(b"reset\x1b")
        assert _until_quiet(t) == b"> reset^C\r\n"
        assert t.command("status").startswith("ok status run=1 ")
        # echo off: nothing but the reply; the setting shows with `echo`
        t.send(b"echo off\r")
        assert _until_quiet(t).startswith(b"> echo off\r\n$ok echo=off*")
        t.send(b"echo\r")
        assert _until_quiet(t).startswith(b"$ok echo=off*")
        assert t.command("echo on") == "ok echo=on"
    finally:
        assert t.stop() == 0


ERRORS = {
    "rate 333": "error:2 rate: unsupported; 50|100|200|250|500|1000|1250|1500 (Hz)",
    "range 8": "error:2 range: bad argument; 1.5|2|4|6 (g)",
    "interval 4000": "error:2 interval: too long; 0..3600 s",
    "mode fast": "error:2 mode: bad argument; allan|raw|binary|both",
    "echo maybe": "error:2 echo: bad argument; [off|on]",
    "units mg": "error:2 units: bad argument; [phys|counts]",
    "stop 3": "error:2 stop: bad argument; no argument",
    "statsu": "error:1 statsu: unknown command; see help",
    "start 4294967295 x": "error:3 start: line too long; 16 chars",
}


def test_every_error_names_command_problem_and_what_is_allowed(tmp_path: Path) -> None:
    t = SimTerm(tmp_path, "--synthetic")
    try:
        t.open()
        for text, want in ERRORS.items():
            assert t.command(text) == want, text
            assert re.fullmatch(r"error:\d \S+: [^;]+; .+", want)
    finally:
        assert t.stop() == 0


def test_help_shows_each_command_with_its_arguments(tmp_path: Path) -> None:
    t = SimTerm(tmp_path, "--synthetic")
    try:
        t.open()
        t.send(b"help\r")
        lines = [t.reply() for _ in range(15)]
        words = [ln.split()[2] for ln in lines]
        assert words == [
            "report",
            "reset",
            "stop",
            "start",
            "rate",
            "status",
            "help",
            "interval",
            "mode",
            "range",
            "save",
            "load",
            "defaults",
            "echo",
            "units",
        ]
        assert "ok help units [phys|counts]" in lines
        assert "ok help rate 50|100|200|250|500|1000|1250|1500 (Hz)" in lines
        assert "ok help mode allan|raw|binary|both" in lines
        assert all(len(ln) + 8 <= 80 for ln in lines)  # $, *CRC, CR LF
        # arguments help shows are accepted
        assert t.command("echo on") == "ok echo=on"
        assert t.command("range 4") == "ok reset range=4"
    finally:
        assert t.stop() == 0


def _report_screen(t: SimTerm, units: str) -> tuple[list[bytes], list[bytes]]:
    """`units <units>`, some seconds of samples, `stop`, `report`: every line
    of the report as sent (through its E line) and the last 23 of them."""
    assert t.line().startswith(b"B,")
    assert t.command("interval 0") == "ok interval=0"  # only the report asked for
    assert t.command(f"units {units}") == f"ok units={units}"
    time.sleep(3)  # some seconds of samples
    assert t.command("stop").startswith("ok stopped n=")  # the summary then equals the rows exactly
    t.send(b"report\r")
    raw = b""
    deadline = time.monotonic() + 30
    while not (end := re.search(rb"\$E,\d+,90\*[0-9A-F]{4}\r\n", raw)):
        assert time.monotonic() < deadline, raw[-300:]
        raw += t.ser.read(max(1, t.ser.in_waiting))
    lines = raw[: end.end()].split(b"\r\n")[:-1]
    head = max(i for i, ln in enumerate(lines) if ln.startswith(b"$H,"))
    return lines[head:], lines[-23:]


def _body(ln: bytes) -> str:
    m = LINE.match(ln + b"\r\n")
    assert m and int(m.group(2), 16) == crc16(m.group(1)), ln
    return m.group(1).decode()


def _recomputed(report: list[bytes], units: str) -> tuple[dict, float]:
    """From the report's own H and L lines, on the host: per channel the
    deviation of each level, N (at the level nearest 1 s) and B (least
    deviation / 0.664 over levels with 8 pairs), each with its level's
    +-% = 100/sqrt(2 pairs), in the summary's units."""
    import math

    from imu_allan.profiles import G0, thesis_profile

    head = dict(kv.split("=", 1) for kv in _body(report[0]).split(",")[2:])
    fs, rng = float(head["fs"]), head["range"]
    assert head["units"] == units
    prof = thesis_profile(rng)
    out: dict = {}
    for ln in report:
        if not ln.startswith(b"$L,"):
            continue
        _, _, ch, level, pairs, acc, _ = _body(ln).split(",")
        k, p = int(level), int(pairs)
        if p:
            out.setdefault(ch, {})[k] = (p, math.sqrt(int(acc, 16) / (2 * 4**k * p)))
    res = {}
    for ch, lv in out.items():
        per = prof.scale(ch).per_count
        acc_ch = ch.startswith("a")
        f_adev = 1.0 if units == "counts" else (per / G0 * 1000 if acc_ch else per)
        f_n = 1.0 if units == "counts" else per * 60
        f_b = 1.0 if units == "counts" else (per / G0 * 1000 if acc_ch else per * 3600)
        kn = min(lv, key=lambda k: (abs(2**k - fs), k))
        kb = min((k for k in lv if lv[k][0] >= 8), key=lambda k: (lv[k][1], k))
        res[ch] = {
            "adev": {k: v[1] * f_adev for k, v in lv.items()},
            "N": lv[kn][1] * math.sqrt(2**kn / fs) * f_n,
            "N%": 100 / math.sqrt(2 * lv[kn][0]),
            "Ntau": 2**kn / fs,
            "B": lv[kb][1] / 0.664 * f_b,
            "B%": 100 / math.sqrt(2 * lv[kb][0]),
            "Btau": 2**kb / fs,
        }
    return res, fs


def _near(shown: str, value: float) -> bool:
    """Within the printed precision: one unit of the 3rd significant digit
    (the device computes in fixed point)."""
    import math

    v = float(shown)
    return v == value or abs(v - value) <= 10 ** (math.floor(math.log10(abs(value))) - 2) * 1.0001


def _summary_checked(report: list[bytes], screen: list[bytes], units: str) -> None:
    # the last 23 lines of an 80x24 terminal hold the whole summary (S lines)
    # and E, at its bottom; above it, with fewer than 15 levels, V and T lines
    assert all(len(ln) <= 80 for ln in screen), [ln for ln in screen if len(ln) > 80]
    assert screen[-1].startswith(b"$E,")
    s_lines = [ln for ln in report if ln.startswith(b"$S,")]
    summary = [_body(ln).split(",", 2)[2] for ln in s_lines]
    levels = len(summary) - 7
    assert len(summary) <= 22 and screen[-1 - len(summary) : -1] == s_lines
    assert report[report.index(s_lines[0]) - 1].startswith(b"$V,")  # the machine lines end above it
    want, fs = _recomputed(report, units)
    chans = ["ax", "ay", "az", "gx", "gy", "gz"]
    if units == "phys":
        assert summary[0].startswith("Allan deviation by tau (s): accel mg at +-1.5 g, gyro deg/s")
    else:
        assert summary[0] == "Allan deviation by tau (s): ADC counts"
    assert summary[1].split() == ["tau_s"] + chans
    for k, row in enumerate(summary[2 : 2 + levels]):
        cells = row.split()
        assert _near(cells[0], 2**k / fs)
        for ch, cell in zip(chans, cells[1:]):
            assert _near(cell, want[ch]["adev"][k]), (ch, k, cell, want[ch]["adev"][k])
    m = re.match(r"N at ([0-9.e-]+) s \+-([0-9.e-]+)%: (.*)$", summary[2 + levels])
    assert m, summary[2 + levels]
    assert m.group(3) == ("m/s/rt(h), deg/rt(h); B: mg, deg/h" if units == "phys" else "count rt(s); B: counts")
    assert _near(m.group(1), want["gx"]["Ntau"]) and _near(m.group(2), want["gx"]["N%"])
    rows = {r.split()[0]: r.split()[1:] for r in summary[3 + levels :]}
    assert list(rows) == ["N", "B", "+-%", "tau_s"]
    for i, ch in enumerate(chans):
        w = want[ch]
        assert _near(rows["N"][i], w["N"]), (ch, rows["N"][i], w["N"])
        assert _near(rows["B"][i], w["B"]), (ch, rows["B"][i], w["B"])
        assert _near(rows["+-%"][i], w["B%"]) and _near(rows["tau_s"][i], w["Btau"]), (ch, rows, w)


def test_report_ends_with_the_summary_screen_in_physical_units(tmp_path: Path) -> None:
    """After `report`, the last 23 lines (a 80x24 terminal with the cursor on
    the empty line below) are the summary and E: at most 80 columns each, a
    title with the units, the deviations in mg and deg/s, N and B with their
    tau and +-%, each recomputed here from the same report's H and L lines."""
    t = SimTerm(tmp_path, "--synthetic", "--fast")
    try:
        t.open()
        report, screen = _report_screen(t, "phys")
    finally:
        t.stop()
    _summary_checked(report, screen, "phys")
    tl = [ln for ln in report if ln.startswith(b"$T,")]
    assert [ln.split(b",")[2] for ln in tl] == [b"ax", b"ay", b"az", b"gx", b"gy", b"gz"]


def test_units_counts_gives_the_summary_in_adc_counts(tmp_path: Path) -> None:
    t = SimTerm(tmp_path, "--synthetic", "--fast")
    try:
        t.open()
        report, screen = _report_screen(t, "counts")
        assert t.command("units") == "ok units=counts"
        assert " units=counts " in t.command("status")
    finally:
        t.stop()
    _summary_checked(report, screen, "counts")
