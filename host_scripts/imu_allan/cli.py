"""The ``imu-allan`` command line."""
from __future__ import annotations

import argparse
import sys

from . import __version__


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="imu-allan",
        description="Host tools for imu-allan, the on-device Allan variance IMU firmware.",
    )
    parser.add_argument("--version", action="version", version=f"imu-allan {__version__}")
    parser.parse_args(argv)
    parser.print_help()
    return 0


if __name__ == "__main__":
    sys.exit(main())
