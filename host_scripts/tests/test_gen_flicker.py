"""`imu-allan gen --flicker`: IEEE 952 bias instability as a bank of Gauss-Markov
processes; streams without it are unchanged."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from imu_allan.noise import gen
from imu_allan.noise import streams as noise
from imu_allan.render.progress import Progress
from imu_allan.stats import allan


def test_flicker_floor_is_0664_b() -> None:
    fl = noise.Flicker(1.0, 100.0, 1 << 20, np.random.SeedSequence(5))
    x = np.concatenate([fl.take(s, 50_000) for s in range(0, 1 << 20, 50_000)])[: 1 << 20]
    r = allan.octave_oavar(x)
    adev = np.sqrt(r.oavar[:, 0]) / 0.6643
    tau = r.ms / 100.0
    # inside the band; the tolerance follows the estimates' scatter (EDF)
    assert np.all(np.abs(adev[(tau >= 0.04) & (tau <= 1)] - 1) < 0.015), adev
    assert np.all(np.abs(adev[(tau > 1) & (tau <= 10)] - 1) < 0.06), adev
    assert np.all(np.abs(adev[(tau > 10) & (tau < 330)] - 1) < 0.2), adev


def test_flicker_does_not_depend_on_the_chunking(tmp_path: Path, run_cli) -> None:
    p = gen.make_params(n=30_000, seed=3, flicker="gx=0.5,az=0.2", white=0, gm_sigma=0, rrw=0)
    a = np.concatenate(list(gen.generate(p)), axis=1)
    b = np.concatenate(list(gen.generate(p, chunk=999)), axis=1)
    assert np.array_equal(a, b)
    assert a[3].std() > 0.3 and a[0].std() == 0  # only the channels asked for
    out = tmp_path / "f.txt"
    assert run_cli("gen", "-n", 2000, "--flicker", "gx=0.5", "-o", out)[0] == 0
    head = out.read_text().splitlines()[0]
    assert "--flicker ax=0.0,ay=0.0,az=0.0,gx=0.5" in head


def test_streams_without_flicker_are_unchanged(tmp_path: Path, run_cli) -> None:
    """Adding the parameter changed neither the numbers nor the first line of
    files that do not use it (older files reproduce)."""
    out = tmp_path / "a.txt"
    assert run_cli("gen", "-n", 500, "--seed", 4, "-o", out)[0] == 0
    head = out.read_text().splitlines()[0]
    assert "--flicker" not in head
    p = gen.make_params(n=500, seed=4)
    want = np.concatenate(list(gen.generate(p)), axis=1)
    got = np.loadtxt(out, dtype=int).T
    assert np.array_equal(got, want)
    nch = len(p.channels)  # the white, GM and RRW streams are the first 3 * nch children
    first = np.random.default_rng(np.random.SeedSequence(4).spawn(3 * nch)[0]).standard_normal(3)
    again = np.random.default_rng(np.random.SeedSequence(4).spawn(4 * nch)[0]).standard_normal(3)
    assert np.array_equal(first, again)


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_only_on_a_terminal_and_only_when_long() -> None:
    quiet = io.StringIO()
    with Progress("x", 10, stream=quiet, delay=0.0) as p:
        p.update(5)
    assert quiet.getvalue() == ""
    tty = _Tty()
    with Progress("reading", 10, stream=tty, delay=0.0) as p:
        p.last = -1.0
        p.update(5)
        assert "reading [" in tty.getvalue() and "50.0%" in tty.getvalue()
    assert tty.getvalue().endswith("\r")  # erased at the end
    fast = _Tty()
    with Progress("x", 10, stream=fast, delay=60.0) as p:
        p.update(5)
    assert fast.getvalue() == ""


def test_progress_erases_exactly_the_columns_it_wrote() -> None:
    """An 82-column line erased only to 72 left 10 columns behind: the erase
    now covers the longest line drawn since, and lines are cut to the
    terminal so that they never wrap (a wrapped line cannot be erased by CR)."""
    tty = _Tty()
    with Progress("x" * 70, None, stream=tty, delay=0.0) as p:
        p.last = -1.0
        p.show("y" * 5)  # 76 columns: "x" * 70, a space, "yyyyy"
        drawn = tty.getvalue()
    assert drawn.startswith("\r" + "x" * 70 + " yyyyy")
    assert tty.getvalue()[len(drawn) :] == "\r" + " " * 76 + "\r"
    long = _Tty()  # StringIO has no terminal: 80 columns, so at most 79 drawn
    with Progress("z" * 100, None, stream=long, delay=0.0) as p:
        p.last = -1.0
        p.show("!")
        line = long.getvalue()
    assert line == "\r" + "z" * 79
    assert long.getvalue()[len(line) :] == "\r" + " " * 79 + "\r"


def test_progress_shorter_line_blanks_what_the_longer_left() -> None:
    tty = _Tty()
    p = Progress("a", None, stream=tty, delay=0.0)
    p.last = -1.0
    p.show("b" * 20)
    p.last = -1.0
    p.show("c")
    assert tty.getvalue().endswith("\ra c" + " " * 19 + "\b" * 19)
    p.close()
    assert tty.getvalue().endswith("\r" + " " * 3 + "\r")
