"""The float64 reference against allantools (an independent implementation)."""

import allantools
import numpy as np
import pytest

from imu_allan.stats.reference import octave_avar


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_octave_avar_matches_allantools_adev(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 50_000 + seed * 1234
    x = np.rint(512 + 3 * rng.standard_normal(n) + np.cumsum(0.01 * rng.standard_normal(n)))
    fs = 100.0
    rows = octave_avar(x, 14)
    taus = np.array([r.m / fs for r in rows])
    t, ad, _, ns = allantools.adev(x, rate=fs, data_type="freq", taus=taus)
    assert np.allclose(t, taus)
    for r, a, count in zip(rows, ad, ns):
        assert r.pairs == count
        assert abs(np.sqrt(r.avar) - a) <= 1e-12 * a


def test_short_streams_have_no_pairs() -> None:
    rows = octave_avar([5, 6, 7], 3)
    assert [r.pairs for r in rows] == [2, 0, 0]
    assert rows[0].avar == pytest.approx(((1.0) ** 2 + (1.0) ** 2) / 4)
    assert np.isnan(rows[1].avar)


# ---- the streaming cascade and the `reference` command --------------------------

import json  # noqa: E402
from pathlib import Path  # noqa: E402

from conftest import CH, exact_acc, thesis_like, write_rows  # noqa: E402

from imu_allan.stats.reference import OctaveCascade  # noqa: E402


def test_cascade_is_independent_of_block_cuts_and_exact() -> None:
    rows = thesis_like(5000, 4)
    x = rows[:, :6].T
    whole = OctaveCascade(10, 6)
    whole.push(x)
    cut = OctaveCascade(10, 6)
    rng = np.random.default_rng(0)
    i = 0
    while i < x.shape[1]:
        j = i + int(rng.integers(0, 300))
        cut.push(x[:, i:j])
        i = j
    assert np.array_equal(whole.pairs(), cut.pairs())
    assert whole.acc() == cut.acc()
    assert np.allclose(whole.avar(), cut.avar(), rtol=1e-14, equal_nan=True)
    for c in range(6):
        codes = [int(v) for v in x[c]]
        for k in (0, 3, 9):
            m = 1 << k
            assert whole.acc()[k][c] == exact_acc(codes, m, 5000 // m - 1)


def test_cascade_limit_is_a_prefix() -> None:
    x = thesis_like(4096, 5)[:, :6].T
    limit = np.array([[(k * 7 + c * 13) % (4096 >> k) for c in range(6)] for k in range(8)])
    lim = OctaveCascade(8, 6, limit)
    lim.push(x)
    for k in range(8):
        for c in range(6):
            p = int(limit[k, c])
            m = 1 << k
            prefix = OctaveCascade(8, 6)
            prefix.push(x[:, : (p + 1) * m])
            assert lim.pairs()[k, c] == p == (prefix.pairs()[k, c] if p else 0)
            assert lim.acc()[k][c] == (prefix.acc()[k][c] if p else 0)


@pytest.mark.parametrize("seed", [7, 8])
def test_reference_command_matches_allantools(tmp_path: Path, run_cli, seed: int) -> None:
    rows = thesis_like(20_000 + seed, seed)
    p = write_rows(tmp_path / "r.txt", rows)
    fs = 50.0
    rc, out, err = run_cli("reference", p, "--fs", "50", "--levels", "15", "--json")
    assert rc == 0, err
    doc = json.loads(out)
    assert doc["header"]["fs_hz"] == 50 and doc["header"]["n"] == len(rows)
    assert doc["errors"] == {}
    assert len(doc["rows"]) == 6 * 15
    for c, ch in enumerate(CH):
        got = [r for r in doc["rows"] if r["channel"] == ch]
        taus = np.array([r["tau_s"] for r in got if r["pairs"]])
        t, ad, _, ns = allantools.adev(rows[:, c].astype(float), rate=fs, data_type="freq", taus=taus)
        assert len(t) >= 12  # allantools leaves out taus with a single pair
        by_m = {r["m"]: r for r in got}
        for tau, a, count in zip(t, ad, ns):
            r = by_m[round(tau * fs)]
            assert r["pairs"] == count and r["covers"] == (count + 1) * r["m"]
            assert abs(r["adev"] - a) <= 1e-12 * a
        assert got[-1]["pairs"] == 0 and got[-1]["avar"] is None  # 2^14 > n / 2


def test_reference_text_and_csv(tmp_path: Path, run_cli) -> None:
    p = write_rows(tmp_path / "r.txt", thesis_like(1000, 1))
    rc, out, _ = run_cli("reference", p, "--fs", "100", "--levels", "4")
    assert rc == 0 and "n 1000 rows" in out and out.count("\ngz ") == 4
    rc, out, _ = run_cli("reference", p, "--fs", "100", "--levels", "4", "--csv")
    assert rc == 0 and len(out.splitlines()) == 25 and out.startswith("channel,level,m,tau_s")
