"""``python -m imu_allan.cli``: the ``imu-allan`` command."""

import sys

from .main import main

sys.exit(main())
