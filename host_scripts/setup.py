"""Builds the optional compiled Allan kernels (imu_allan/stats/_ckernels.c, ck_*.c)
and the ROS 2 sqlite3 bags' page reader (imu_allan/sources/_db3pages.c).

Everything else about the package is in pyproject.toml.  The extension is
optional: where no C compiler is available the install still succeeds and
imu_allan.stats.kernels falls back to its numpy path.  In a checkout,
`make ext` (run by `make deps`, `make pytest` and `make bench`) builds it in
place next to kernels.py.
"""

import sys

from setuptools import Extension, setup

# -Wno-psabi: the 32-byte vector helpers are inlined; their ABI note does not apply.
ARGS = [] if sys.platform == "win32" else ["-O3", "-std=gnu99", "-Wno-psabi"]

SOURCES = [f"imu_allan/stats/{f}.c" for f in ("_ckernels", "ck_core", "ck_octave", "ck_phase", "ck_text")]

setup(
    ext_modules=[
        Extension(
            "imu_allan.stats._ckernels",
            SOURCES,
            depends=["imu_allan/stats/ckernels.h"],
            extra_compile_args=ARGS,
            optional=True,
        ),
        Extension(  # a ROS 2 sqlite3 bag's rows from its pages (sources/db3pages.py)
            "imu_allan.sources._db3pages",
            ["imu_allan/sources/_db3pages.c"],
            extra_compile_args=ARGS,
            optional=True,
        ),
    ]
)
