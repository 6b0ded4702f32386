"""The statistics layer: float64 (and exact integer) numbers from samples;
estimators and intervals only (the noise processes, their simulators and the
fitters are the noise catalogue, imu_allan.noise).

kernels.py    offsets and sums of squares shared by the engines; the octave and
              any-m sums, from the compiled _ckernels (C) or numpy
allan.py      Allan-family variances and the streaming octave engine
reference.py  the device's statistic recomputed (exact acc, float64 avar)
edf.py        equivalent degrees of freedom and chi-squared intervals
psd.py        Welch PSD and the terms' PSD levels
"""

TAU_KINDS = ("octave", "decade", "log", "all")
"""The tau grids allan.tau_grid builds; here (numpy-free) so that the
``imu-allan`` parser names them without importing numpy."""
