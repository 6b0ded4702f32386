"""imu-allan host tools: decode on-device Allan results, compute the float64 reference."""

__version__ = "0.1.0"

CHANNELS = ("ax", "ay", "az", "gx", "gy", "gz")
