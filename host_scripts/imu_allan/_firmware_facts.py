"""The facts the host shares with the firmware, generated from firmware/ by
`make facts` (scripts/firmware_facts.py); tests/test_firmware_facts.py fails
when the firmware and this file part.  Edit the firmware, not this file."""

PROTO_VERSION = 1
"""`proto=` of the boot line and every report header (vocab.h PROTO_VERSION)."""

RATES_HZ = (50, 100, 200, 250, 500, 1000, 1250, 1500)
"""Sample rates the device offers, ascending (vocab.h VOCAB_RATES)."""

CODE_MAX = 1023
"""Largest ADC code: a 10-bit converter (config.h ALLAN_CODE_MAX)."""

CHANNELS = ("ax", "ay", "az", "gx", "gy", "gz")
"""Sensor channels, in the order of every row, report and table (vocab.c vocab_channels)."""

COLUMNS = ("ax", "ay", "az", "gx", "gy", "gz", "temp")
"""Columns of a sample set (rows files, raw rows, binary frames): the sensors, then the
temperature (adc.h ADC_COLUMNS of them)."""

MODES = ("allan", "raw", "binary", "both")
"""Output modes, in the order of their numbers (vocab.c vocab_modes)."""

RANGES_G = ("1.5", "2", "4", "6")
"""Accelerometer ranges in g, in the order of their numbers (vocab.c vocab_ranges)."""

UNITS = ("phys", "counts")
"""The `units` setting's words (vocab.c vocab_units)."""

ONOFF = ("off", "on")
"""The `echo` setting's words, off and on (vocab.c vocab_onoff)."""

CONFIG_SOURCES = ("saved", "blank", "corrupt", "defaults", "infeasible")
"""Where the settings in force came from, `cfg=` (vocab.c vocab_sources)."""

RESET_CAUSES = ("por", "ext", "bor", "wdt")
"""Reset causes, `reset=`, MCUSR's PORF EXTRF BORF WDRF (vocab.c vocab_causes)."""

COMMANDS = (
    "report",
    "reset",
    "stop",
    "start",
    "rate",
    "status",
    "help",
    "interval",
    "mode",
    "range",
    "save",
    "load",
    "defaults",
    "echo",
    "units",
)
"""Command words the device accepts (the firmware's cmd_words table)."""

COMMAND_ARGS = {
    "report": "none",
    "reset": "none",
    "stop": "none",
    "start": "count",
    "rate": "rate",
    "status": "none",
    "help": "none",
    "interval": "seconds",
    "mode": "mode",
    "range": "range",
    "save": "none",
    "load": "none",
    "defaults": "none",
    "echo": "onoff",
    "units": "units",
}
"""The argument each command takes (the firmware's cmd_arg table): none, count, rate,
seconds, mode, range, onoff or units."""

ERROR_CODES = {"unknown": 1, "arg": 2, "long": 3, "state": 4, "lost": 5, "byte": 6, "timeout": 7}
"""`error:N` codes of a reply, by cause (the firmware's CMD_ERR_*)."""

INTERVAL_MAX_S = 3600
"""Longest report interval in seconds (vocab.h VOCAB_INTERVAL_MAX_S)."""

COMMAND_LINE_MAX = 16
"""Longest command line the device keeps, in characters (COMMAND_LINE_MAX)."""
