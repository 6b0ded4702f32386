"""The board's sample set: its channel names, code range and rates.  Their home
is the firmware; the host's copy is _firmware_facts.py (`make facts`)."""

from ._firmware_facts import CHANNELS, CODE_MAX, COLUMNS, RATES_HZ

FS_LIMITS_HZ = (1e-6, 1e9)
"""Sample rates the host tools compute with: far beyond any IMU's on both
sides, and close enough to 1 that every tau, its square and the spectrum's
frequencies stay normal float64 numbers (a rate of 1e308 Hz or 1e-300 Hz
made the fits divide infinities)."""

__all__ = ["CHANNELS", "CODE_MAX", "COLUMNS", "RATES_HZ", "FS_LIMITS_HZ"]
