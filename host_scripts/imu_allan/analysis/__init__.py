"""The analysis layer: samples and device reports into finished documents (plain data).

pipeline.py  analyze(): the whole analysis of one recording (curves, intervals, terms, checks)
check.py     a device report checked against the float64 reference on the same samples
sweep.py     the same noise at every device rate (simulator or board): the rate study
thermal.py   recordings at several temperatures: the terms' drift with temperature
"""
