"""The whole-curve fit runs its linear algebra on one BLAS thread (its matrices are tens of
points across, where threads only wait) and gives the libraries their thread count back,
with the same result as on the threads it found."""

from __future__ import annotations

import numpy as np
import pytest

from imu_allan.noise import curve, fit
from imu_allan.stats import allan, edf

threadpoolctl = pytest.importorskip(
    "threadpoolctl", reason="threadpoolctl absent: the fit runs on the BLAS threads it finds"
)


def _blas_threads() -> list[int]:
    return [i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"]


def _stream() -> np.ndarray:
    """White noise (N = 0.01 at 100 Hz) plus a random walk: a textbook two-term stream."""
    rng = np.random.default_rng(7)
    n = 200_000
    return 0.01 * 10.0 * rng.standard_normal(n) + np.cumsum(rng.standard_normal(n)) * 1e-4 / 10.0


def test_fit_holds_blas_to_one_thread_and_restores(monkeypatch):
    if not _blas_threads():
        pytest.skip("no BLAS library that threadpoolctl can see")
    seen: list[list[int]] = []
    real = curve._nnls

    def spy(*args, **kw):
        if len(seen) < 3:  # threadpool_info costs milliseconds: the first calls tell
            seen.append(_blas_threads())
        return real(*args, **kw)

    monkeypatch.setattr(curve, "_nnls", spy)
    x = _stream()
    ms = allan.tau_grid("octave", allan.max_m("oavar", x.size))
    var = allan.oavar(x, ms)[0]
    efn = edf.edf_function(ms, np.full(ms.size, x.size + 1), np.ones(ms.size, dtype=np.int64))
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):
        if set(_blas_threads()) != {2}:
            pytest.skip("the BLAS libraries here run on one thread only")
        free = fit.fit_curve.__wrapped__(ms / 100.0, var, efn, fs=100.0)  # the fit as it was
        on_free = seen[:]
        seen.clear()
        held = fit.fit_curve(ms / 100.0, var, efn, fs=100.0)
        after = _blas_threads()
    assert on_free and all(set(v) == {2} for v in on_free)
    assert seen and all(set(v) == {1} for v in seen)
    assert set(after) == {2}
    for k in ("N", "K"):  # the same fit on one thread as on two
        assert held.terms[k].value == free.terms[k].value
        assert (held.terms[k].low, held.terms[k].high) == (free.terms[k].low, free.terms[k].high)
