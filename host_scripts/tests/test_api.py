"""The public Python API (imu_allan.adev ...): the same numbers as allantools
and as a direct evaluation of the definitions, intervals around the value,
and the device side reading a log."""

from __future__ import annotations

import math

import numpy as np
import pytest

import imu_allan

allantools = pytest.importorskip("allantools")


@pytest.mark.parametrize("ours,theirs", [("adev", "adev"), ("oadev", "oadev"), ("mdev", "mdev"), ("hdev", "ohdev")])
def test_same_numbers_as_allantools(ours: str, theirs: str) -> None:
    x = np.random.default_rng(4).standard_normal(5000) + 0.01 * np.arange(5000) ** 0.5
    dev = getattr(imu_allan, ours)(x, rate=50.0, taus="decade")
    t, want, _, ns = getattr(allantools, theirs)(x, rate=50.0, data_type="freq", taus=dev.taus)
    assert np.allclose(t, dev.taus) and np.allclose(dev.devs, want, rtol=1e-9)
    assert np.all(dev.low < dev.devs) and np.all(dev.devs < dev.high) and np.all(dev.edf > 0)


def test_oadev_by_the_definition() -> None:
    """NIST SP 1065 eq. 8 evaluated term by term at tau = 3/rate."""
    x = np.random.default_rng(9).standard_normal(400)
    m, n = 3, 400
    X = np.concatenate(([0.0], np.cumsum(x)))
    terms = [(X[i + 2 * m] - 2 * X[i + m] + X[i]) ** 2 for i in range(n - 2 * m + 1)]
    want = math.sqrt(sum(terms) / (2 * m * m * len(terms)))
    dev = imu_allan.oadev(x, rate=10.0, taus=[0.3])
    assert dev.taus.tolist() == [0.3] and dev.devs[0] == pytest.approx(want, rel=1e-12)
    assert dev.ns.tolist() == [len(terms)]


def test_noise_terms_of_white_noise() -> None:
    """White rate noise of sigma 0.2 per sample at 100 Hz: N = 0.2 / sqrt(100)."""
    x = 0.2 * np.random.default_rng(2).standard_normal(200_000)
    fit = imu_allan.noise_terms(x, rate=100.0)
    n = fit.terms["N"]
    assert n.value == pytest.approx(0.02, rel=0.03) and n.low <= 0.02 <= n.high


def test_too_short_or_bad_rate_is_refused() -> None:
    with pytest.raises(ValueError):
        imu_allan.adev([1.0, 2.0, 3.0])
    with pytest.raises(ValueError):
        imu_allan.oadev(np.zeros(100), rate=0.0)


def test_device_side(tmp_path, run_cli) -> None:
    rows = tmp_path / "imu.txt"
    rc, _, err = run_cli("gen", "-n", "2000", "--seed", "3", "-o", rows)
    assert rc == 0, err
    codes = imu_allan.read_rows(rows)
    assert codes.shape == (7, 2000) and codes.dtype == np.uint16
    cap = imu_allan.read_capture(rows)  # a rows file read as a capture: every line is a raw row
    assert cap.samples.shape[1] == 2000 and np.array_equal(cap.samples, codes)
