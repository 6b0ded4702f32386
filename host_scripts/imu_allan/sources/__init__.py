"""The sources layer: every input format, read into samples (and device reports).

detect.py  what a file is (a device capture, a rows file, a CSV, gzip or not) and its reader
rows.py    the thesis rows file (one sample a line): its reader and its writer
"""
