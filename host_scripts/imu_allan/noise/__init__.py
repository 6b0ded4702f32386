"""The noise catalogue: processes that simulate themselves and know their theory
(processes.py, the model as their sum), the whole-curve fitter (fit.py; its
problem in curve.py, its selection in select.py, its reading in reading.py),
the IEEE 952 term fit (terms.py, identify.py), the thesis' streams and model
(streams.py, model.py, thesis.py), the synthetic generator (gen.py, its words in
words.py) and the continuous sensor model (sensor.py).

The processes are loaded on first use (PEP 562), so that the CLI parser can read
words.py without importing numpy.
"""

from __future__ import annotations

from typing import Any

__all__ = ["AR1", "GM", "LP", "QN", "RW", "WN", "Flicker", "Model", "Process", "Ramp", "Resonance", "Sine"]


def __getattr__(name: str) -> Any:
    if name == "Resonance":
        from .resonance import Resonance

        return Resonance
    if name == "Flicker":
        from .flicker import Flicker

        return Flicker
    if name in __all__:
        from . import processes

        return getattr(processes, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
