"""The board's sample set: one home for its channel names, code range and rates."""

CHANNELS = ("ax", "ay", "az", "gx", "gy", "gz")
"""Sensor channels, in the order of every row, report and table."""

COLUMNS = CHANNELS + ("temp",)
"""Columns of a sample set (rows files, raw rows, binary frames): the sensors and the temperature."""

CODE_MAX = 1023
"""Largest 10-bit ADC code."""

RATES_HZ = (50, 100, 200, 250, 500, 1000, 1250, 1500)
"""Sample rates the device offers (firmware/vocab.h; docs/protocol.md)."""

FS_LIMITS_HZ = (1e-6, 1e9)
"""Sample rates the host tools compute with: far beyond any IMU's on both
sides, and close enough to 1 that every tau, its square and the spectrum's
frequencies stay normal float64 numbers (a rate of 1e308 Hz or 1e-300 Hz
made the fits divide infinities)."""
