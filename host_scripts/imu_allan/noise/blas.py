"""The whole-curve fit's linear algebra on one BLAS thread.

The fit's matrices are tens of points across (the octave points' covariance, its Cholesky
factor and inverse, the few corrections of an L-BFGS-B search), where OpenBLAS's threads only
cost: each call hands its work to them and waits.  On a two-core machine busy with other
work the waits are counted as the fit's CPU time: a real accelerometer's resonance search
(fit._res_range's L-BFGS-B) took 35-45 ms a call with numpy's and scipy's default threads,
7-9 ms on one.  The results do not depend on it (the same on every real unit's channel).
threadpoolctl sets the thread count of the BLAS libraries loaded, and restores it after;
without it the fit runs as before."""

from __future__ import annotations

import contextlib
import functools
from typing import Any, Callable, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

_CONTROLLER: Any = None


def one_thread(fn: F) -> F:
    """``fn`` run with every loaded BLAS library held to one thread."""

    @functools.wraps(fn)
    def run(*args: Any, **kw: Any) -> Any:
        with _limit():
            return fn(*args, **kw)

    return run  # type: ignore[return-value]


def _limit() -> contextlib.AbstractContextManager:
    global _CONTROLLER
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # the same fit, only slower where other work shares the cores
        return contextlib.nullcontext()
    if _CONTROLLER is None:  # once a process: it finds the libraries loaded (numpy's and scipy's)
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1, user_api="blas")
