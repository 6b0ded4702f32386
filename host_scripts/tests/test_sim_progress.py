"""`imu-allan sim`'s progress line: how far the simulator has read its rows
file, read from /proc/PID/fdinfo of a real process (Linux)."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from imu_allan.device.simrun import _AdcWatch, _count_rows, _header_rate

pytestmark = pytest.mark.skipif(not Path("/proc/self/fdinfo").is_dir(), reason="no /proc (not Linux)")


def _rows_file(path: Path, n: int) -> None:
    path.write_text(
        "# imu-allan gen -n 1000 --fs 50\n# columns: ax ay az gx gy gz temp "
        "(10-bit ADC codes), 50 Hz\n" + "".join(f"{i % 10}\t1\t2\t3\t4\t5\t6\n" for i in range(n))
    )


def test_rows_and_rate_of_a_gen_file(tmp_path: Path) -> None:
    f = tmp_path / "imu.tsv"
    _rows_file(f, 1000)
    rows, head = _count_rows(str(f))
    assert rows == 1000 and f.read_bytes()[head:].startswith(b"0\t1\t2")
    assert _header_rate(str(f)) == 50.0


def test_a_reader_halfway_shows_half_the_simulated_seconds(tmp_path: Path) -> None:
    f = tmp_path / "imu.tsv"
    _rows_file(f, 20000)
    head = f.read_text().index("0\t1")
    half = head + (f.stat().st_size - head) // 2
    child = subprocess.Popen(
        [
            sys.executable,
            "-c",
            f"import sys,time; f=open(sys.argv[1],'rb',buffering=0); "
            f"f.read({half}); print(1, flush=True); time.sleep(30)",
            str(f),
        ],
        stdout=subprocess.PIPE,
    )
    try:
        assert child.stdout.readline() == b"1\n"
        watch = _AdcWatch(child.pid, str(f), None)  # the rate from the header
        text = watch.text(wall=2.0)
        assert text is not None and text.startswith("200 of 400 s simulated (50%)"), text
        assert "100.0x real time, 2 s left" in text
        watch = _AdcWatch(child.pid, str(f), "100")  # --fs given
        assert watch.text(wall=2.0).startswith("100 of 200 s simulated (50%), 50.0x")
    finally:
        child.kill()
        child.wait()
    time.sleep(0.05)
    assert watch.text(wall=3.0) is None  # the process is gone: nothing shown
