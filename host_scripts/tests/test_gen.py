"""Synthetic streams: reproducible, and the noise model's parameters come back."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import numpy as np
import pytest

from imu_allan.noise.gen import THESIS, generate, make_params
from imu_allan.sources.rows import read_rows


def _gen(run_cli, path: Path, *args) -> np.ndarray:
    rc, out, err = run_cli("gen", *args, "-o", path)
    assert rc == 0, err
    return read_rows(path).astype(float)


def test_reproducible_and_self_describing(tmp_path: Path, run_cli) -> None:
    a = _gen(run_cli, tmp_path / "a.txt", "-n", 5000, "--seed", 9, "--white", "gx=1.5")
    b = _gen(run_cli, tmp_path / "b.txt", "-n", 5000, "--seed", 9, "--white", "gx=1.5")
    c = _gen(run_cli, tmp_path / "c.txt", "-n", 5000, "--seed", 10, "--white", "gx=1.5")
    assert (tmp_path / "a.txt").read_bytes() == (tmp_path / "b.txt").read_bytes()
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    head = (tmp_path / "a.txt").read_text().splitlines()[0]
    assert head.startswith("# imu-allan gen ") and "gx=1.5" in head and "--seed 9" in head
    argv = shlex.split(head[len("# imu-allan ") :])  # the header's command remakes the file
    assert run_cli(*argv, "-o", tmp_path / "d.txt")[0] == 0
    assert (tmp_path / "d.txt").read_bytes() == (tmp_path / "a.txt").read_bytes()
    assert a.shape == (7, 5000) and np.abs(a.mean(axis=1) - THESIS["offset"]).max() < 1


def test_chunking_does_not_change_the_stream() -> None:
    p = make_params(n=10_000, seed=3, rrw=0.01)
    one = np.concatenate(list(generate(p)), axis=1)
    many = np.concatenate(list(generate(p, chunk=777)), axis=1)
    assert np.array_equal(one, many)


def test_json_params(tmp_path: Path, run_cli) -> None:
    _gen(
        run_cli,
        tmp_path / "a.txt",
        "-n",
        10,
        "--gm-tau",
        "5",
        "--drift",
        "gz=-0.5",
        "--json-params",
        tmp_path / "p.json",
    )
    p = json.loads((tmp_path / "p.json").read_text())
    assert p["n"] == 10 and p["seed"] == 1 and p["fs_hz"] == 100.0 and p["kind"] == "noise"
    assert p["gm_tau"] == dict.fromkeys(p["channels"], 5.0)
    assert p["drift"]["gz"] == -0.5 and p["drift"]["gx"] == 0.0
    assert p["white"]["gx"] == 0.85 and p["white"]["ax"] == 2.0
    assert p["units"]["white"].startswith("counts")


def test_white_noise_sigma_is_recovered(tmp_path: Path, run_cli) -> None:
    x = _gen(
        run_cli,
        tmp_path / "w.txt",
        "-n",
        200_000,
        "--gm-sigma",
        "0",
        "--rrw",
        "0",
        "--white",
        "ax=5,ay=20",
        "--offset",
        "ay=512",
    )
    want = np.array([5, 20] + list(THESIS["white"][2:6]))
    sd = x[:6].std(axis=1)  # + quantization noise, 1/12 count^2 (sigma >= 0.5)
    assert np.allclose(sd, np.sqrt(want**2 + 1 / 12), rtol=0.03)


def test_gauss_markov_is_recovered(tmp_path: Path, run_cli) -> None:
    fs, tau, sigma = 100.0, 1.0, 30.0
    x = _gen(
        run_cli,
        tmp_path / "g.txt",
        "-n",
        200_000,
        "--fs",
        fs,
        "--white",
        "0",
        "--rrw",
        "0",
        "--gm-sigma",
        sigma,
        "--gm-tau",
        tau,
        "--offset",
        512,
        "--seed",
        2,
    )
    for row in x[:6]:
        y = row - row.mean()
        assert y.std() == pytest.approx(sigma, rel=0.1)
        a = np.dot(y[1:], y[:-1]) / np.dot(y, y)
        assert -1 / (fs * np.log(a)) == pytest.approx(tau, rel=0.15)


def test_rate_random_walk_steps(tmp_path: Path, run_cli) -> None:
    x = _gen(run_cli, tmp_path / "r.txt", "-n", 100_000, "--kind", "walk", "--seed", 5)
    steps = np.diff(x[:6], axis=1)
    assert np.allclose(steps.std(axis=1), np.sqrt(2.0**2 + 1 / 6), rtol=0.03)
    assert x.min() >= 0 and x.max() <= 1023


def test_scenario_kinds(tmp_path: Path, run_cli) -> None:
    sq = _gen(run_cli, tmp_path / "s.txt", "-n", 128, "--kind", "square")
    assert sq[0, :4].tolist() == [0, 1023, 0, 1023]
    assert sq[5, :64].tolist() == [0] * 32 + [1023] * 32
    assert set(sq[6]) == {63}
    cl = _gen(run_cli, tmp_path / "c.txt", "-n", 5000, "--kind", "clip")
    assert all((cl[c] == 0).any() and (cl[c] == 1023).any() for c in range(6))
    dr = _gen(run_cli, tmp_path / "d.txt", "-n", 100_000, "--kind", "drift", "--drift", "gx=0.2")
    gx = dr[3]
    assert gx[-10_000:].mean() - gx[:10_000].mean() == pytest.approx(0.2 * 900, rel=0.05)


@pytest.mark.parametrize(
    "args, message",
    [
        (("--white", "gq=1"), "unknown channel 'gq'"),
        (("--white", "x"), "expected a number or CH=NUMBER"),
        (("--gm-tau", "0"), "out of range"),
        (("--fs", "0"), "must be a positive number"),
    ],
)
def test_bad_parameters_are_one_line(tmp_path: Path, run_cli, args, message) -> None:
    rc, out, err = run_cli("gen", "-n", 10, *args, "-o", tmp_path / "x.txt")
    assert rc == 2 and message in err and err.count("\n") == 1
