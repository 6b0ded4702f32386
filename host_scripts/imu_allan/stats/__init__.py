"""The statistics layer: float64 (and exact integer) numbers from samples.

kernels.py    offsets and sums of squares shared by the engines; the octave and
              any-m sums, from the compiled _ckernels (C) or numpy
allan.py      Allan-family variances and the streaming octave engine
reference.py  the device's statistic recomputed (exact acc, float64 avar)
edf.py        equivalent degrees of freedom and chi-squared intervals
terms.py      the IEEE 952 noise terms fitted to a curve
psd.py        Welch PSD and the terms' PSD levels
noise.py      the one noise simulator; gen.py (synthetic codes) and
model.py      (the thesis model and FIT%) use it
"""
