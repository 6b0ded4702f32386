"""The board's sample set: its channel names, code range and rates.  Their home
is the firmware; the host's copy is _firmware_facts.py (`make facts`)."""

from ._firmware_facts import CHANNELS, CODE_MAX, COLUMNS, RATES_HZ

__all__ = ["CHANNELS", "CODE_MAX", "COLUMNS", "RATES_HZ"]
