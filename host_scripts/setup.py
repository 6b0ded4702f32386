"""Builds the optional compiled Allan kernels (imu_allan/stats/_ckernels.c).

Everything else about the package is in pyproject.toml.  The extension is
optional: where no C compiler is available the install still succeeds and
imu_allan.stats.kernels falls back to its numpy path.  In a checkout,
`make ext` (run by `make deps`, `make pytest` and `make bench`) builds it in
place next to kernels.py.
"""
import sys

from setuptools import Extension, setup

# -fopenmp-simd: honour the `omp simd reduction` pragmas (no OpenMP runtime).
ARGS = [] if sys.platform == "win32" else ["-O3", "-fopenmp-simd", "-std=gnu99", "-Wno-psabi"]

setup(ext_modules=[Extension("imu_allan.stats._ckernels", ["imu_allan/stats/_ckernels.c"],
                             extra_compile_args=ARGS, optional=True)])
