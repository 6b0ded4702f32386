"""The noise catalogue (processes.py) and the whole-curve fitter (fit.py)."""
from .processes import AR1, GM, LP, QN, RW, WN, Flicker, Model, Process, Ramp, Sine

__all__ = ["AR1", "GM", "LP", "QN", "RW", "WN", "Flicker", "Model", "Process", "Ramp", "Sine"]
