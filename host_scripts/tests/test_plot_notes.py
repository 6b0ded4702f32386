"""Plots a person puts in a report: B's line at the deviation it makes, a log grid's
last points not stretching the axis, a skipped plot said."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest
from conftest import report_lines, thesis_like, write_rows


@pytest.fixture(scope="module")
def rows() -> np.ndarray:
    return thesis_like(1 << 14, 5)


def test_device_log_alone_says_the_psd_plot_is_skipped(rows: np.ndarray, tmp_path: Path, run_cli) -> None:
    log = tmp_path / "dev.log"
    log.write_bytes(b"".join(report_lines(rows, 12, extra=",mode=allan,range=1.5")))
    rc, _, err = run_cli("analyze", log, "--plot", tmp_path / "figs", "--no-model")
    assert rc == 0, err
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == ["adev_accelerometer.png", "adev_gyroscope.png"]
    for group in ("accelerometer", "gyroscope"):
        assert f"{group} PSD plot skipped: a device log carries results, not samples" in err


def test_b_line_and_log_grid_limits(tmp_path: Path, monkeypatch) -> None:
    """The B label says its line is flat at 0.664 B; with --taus log the y axis is set by the
    points whose interval is drawn, not by the EDF-1 intervals at m = n/2."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from imu_allan.cli import main as cli
    from imu_allan.render import plots

    seen: list = []
    real_save = plots._save

    def keep(plt_, fig, path):  # look at the figure before it is closed
        words = [t.get_text() for lg in fig.legends for t in lg.get_texts()]  # the figure's one legend
        for ax in fig.axes:
            seen.append((Path(path).name, ax.get_title(), ax.get_ylim(), words))
        return real_save(plt_, fig, path)

    monkeypatch.setattr(plots, "_save", keep)
    from imu_allan.noise import gen

    p = gen.make_params(n=1 << 15, seed=3, white=1.0, flicker=0.5, gm_sigma=0, rrw=0)
    data = write_rows(tmp_path / "imu.txt", np.concatenate(list(gen.generate(p)), axis=1).T)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        assert (
            cli.main(
                [
                    "analyze",
                    str(data),
                    "--fs",
                    "100",
                    "--taus",
                    "log",
                    "--no-model",
                    "--plot",
                    str(tmp_path / "figs"),
                    "--json",
                ]
            )
            == 0
        )
    doc = json.loads(buf.getvalue())
    plt.close("all")
    adev = [s for s in seen if s[0].startswith("adev_") and s[1]]  # the residual panels have no title
    assert len(adev) == 6
    assert any(t.startswith("bias instability B = ") for s in adev for t in s[3])  # some channel has its B
    stretched = 0
    for _, ch, ylim, legend in adev:
        b = [t for t in legend if t.startswith("bias instability B = ")]
        if b:
            assert "flat at 0.664 B" in b[0], b
        pts = [p for p in doc["channels"][ch]["curve"] if p["dev"]]
        assert min(p["edf"] for p in pts) < 3  # the log grid reaches EDF-1 points
        drawn = [p["high"] for p in pts if p["edf"] >= plots.MIN_EDF_BAND] + [p["dev"] for p in pts]
        # no more than a factor 1.5 beyond the highest drawn interval or point ...
        assert ylim[1] <= max(drawn) * 1.5 * 1.0001, (ch, ylim, max(drawn))
        # ... where the EDF-1 intervals would have stretched it
        stretched += max(p["high"] for p in pts if p["edf"] < plots.MIN_EDF_BAND) > ylim[1]
    assert stretched >= 3, stretched
