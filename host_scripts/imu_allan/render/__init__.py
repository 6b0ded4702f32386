"""The rendering layer: finished documents and live states into what a person reads.

text.py      the text tables and summaries a person reads
formats.py   the same documents as JSON, CSV and YAML (Kalibr, imu_utils) for other programs
plots.py     the figures (matplotlib, loaded only when a figure is asked for)
screen.py    the monitor's live view of a port (full screen or plain lines)
terminal.py  the terminal itself: screen size, alternate screen, raw keys, line editing
"""
