"""The old path of stats/reference.py: bench/run.py still imports
``imu_allan.reference``; this name stays the same module until it moves."""
import sys

from .stats import reference as _reference

sys.modules[__name__] = _reference
