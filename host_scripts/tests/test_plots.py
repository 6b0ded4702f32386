"""Figures a reader trusts, checked on the rendered figure (Agg): one legend per
figure, below the panels and clear of every data artist; plain labels with each
axis' value in the units datasheets quote; every fitted line only over the taus
the data cover; the PNG as large as the figure says."""

from __future__ import annotations

import contextlib
import io
import json
import struct
from pathlib import Path

import numpy as np
import pytest
from conftest import report_lines, thesis_like, write_rows
from matplotlib.transforms import Bbox

G0 = 9.80665
DATASHEET = {"gyro": {"N": 60.0, "B": 3600.0, "K": 216000.0}, "acc": {"N": 60.0, "B": 1e6 / G0, "K": 216000.0}}


def _render(argv: list[str], monkeypatch: pytest.MonkeyPatch) -> tuple[dict, list[dict]]:
    """Run analyze with --json and look at each figure just before it is saved."""
    import matplotlib

    matplotlib.use("Agg")
    from imu_allan.cli import main as cli
    from imu_allan.render import plots

    seen: list[dict] = []
    real_save = plots._save

    def look(plt_, fig, path):
        renderer = fig.canvas.get_renderer()
        fig.canvas.draw()
        axes = []
        for ax in fig.axes:
            artists = [a for a in ax.lines + ax.collections + ax.patches if a.get_visible()]
            lines = []
            for ln in ax.lines:
                x, y = np.asarray(ln.get_xdata(), float), np.asarray(ln.get_ydata(), float)
                shown = np.isfinite(x) & np.isfinite(y)
                if ln.get_linestyle() in ("None", "none", "", " "):
                    continue  # points (flagged, device), not a line
                if shown.any() and not np.all(x[shown] == x[shown][0]):  # not a vertical or single mark
                    lines.append((x[shown].min(), x[shown].max(), ln.get_linestyle(), ln.get_marker()))
            axes.append(
                {
                    "title": ax.get_title(),
                    "legend": ax.get_legend(),
                    "box": ax.get_window_extent(renderer),
                    "artists": [a.get_window_extent(renderer) for a in artists],
                    "lines": lines,
                    "xlog": ax.get_xscale() == "log",
                }
            )
        seen.append(
            {
                "name": Path(path).name,
                "path": Path(path),
                "legends": [
                    (lg, lg.get_window_extent(renderer), [t.get_text() for t in lg.get_texts()]) for lg in fig.legends
                ],
                "axes": axes,
                "figbox": fig.bbox,
                "size_px": tuple(round(v * fig.dpi) for v in fig.get_size_inches()),
                "dpi": plots.DPI,
                "fig_inches": tuple(fig.get_size_inches()),
            }
        )
        return real_save(plt_, fig, path)

    monkeypatch.setattr(plots, "_save", look)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        assert cli.main(argv + ["--json"]) == 0
    return json.loads(buf.getvalue()), seen


@pytest.fixture(scope="module")
def rendered(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, list[dict]]:
    from imu_allan.noise import gen

    d = tmp_path_factory.mktemp("plots")
    p = gen.make_params(n=1 << 15, seed=3, white=1.0, flicker=0.5, gm_sigma=0, rrw="gx=0.02,ax=0.02")
    data = write_rows(d / "imu.txt", np.concatenate(list(gen.generate(p)), axis=1).T)
    with pytest.MonkeyPatch.context() as mp:
        return _render(["analyze", str(data), "--fs", "100", "--no-warmup", "--plot", str(d / "figs")], mp)


def _png_size(path: Path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR"
    return struct.unpack(">II", head[16:24])


def test_the_png_is_the_figure_at_its_resolution(rendered) -> None:
    _, figs = rendered
    assert sorted(f["name"] for f in figs) == [
        "adev_accelerometer.png",
        "adev_gyroscope.png",
        "psd_accelerometer.png",
        "psd_gyroscope.png",
    ]
    for f in figs:
        w, h = _png_size(f["path"])
        want = [v * f["dpi"] for v in f["fig_inches"]]
        assert abs(w - want[0]) <= 1 and abs(h - want[1]) <= 1, (f["name"], (w, h), want)
        assert 1200 <= w <= 2000 and 450 <= h <= 1000, (f["name"], w, h)  # three panels, readable on a page


def test_one_legend_per_figure_outside_the_data(rendered) -> None:
    _, figs = rendered
    for f in figs:
        assert [a["legend"] for a in f["axes"]] == [None] * len(f["axes"]), f["name"]
        assert len(f["legends"]) == 1, f["name"]
        _, box, _ = f["legends"][0]
        fig = f["figbox"]
        assert fig.x0 <= box.x0 and box.x1 <= fig.x1 and fig.y0 <= box.y0 and box.y1 <= fig.y1  # not cut off
        for a in f["axes"]:
            assert not box.overlaps(a["box"]), (f["name"], a["title"])
            # what is drawn of each artist: its extent clipped to its axes
            drawn = [Bbox.intersection(b, a["box"]) for b in a["artists"]]
            hit = [b for b in drawn if b is not None and box.overlaps(b)]
            assert hit == [], (f["name"], a["title"], hit)


def test_labels_are_plain_words_with_every_axis_value(rendered) -> None:
    doc, figs = rendered
    for f in figs:
        if not f["name"].startswith("adev_"):
            continue
        _, _, texts = f["legends"][0]
        chans = [a["title"] for a in f["axes"] if a["title"]]
        assert all("level" not in t and "line at" not in t for t in texts)  # no jargon
        n = next(t for t in texts if t.startswith("white noise N = "))
        for ch in chans:
            c = doc["channels"][ch]
            want = float(f"{c['terms']['N']['value'] * DATASHEET[c['kind']]['N']:.3g}")
            assert f"{want:g} ({ch}" in n, (n, ch)
        assert (" deg/sqrt(h)," if f["name"] == "adev_gyroscope.png" else " m/s/sqrt(h),") in n
        for term, words, unit in (("B", "bias instability B = ", ("deg/h", "ug")), ("K", "rate random walk K = ", ())):
            have = [ch for ch in chans if doc["channels"][ch]["terms"][term]]
            label = [t for t in texts if t.startswith(words)]
            assert len(label) == (1 if have else 0), (f["name"], term, texts)
            for ch in have:
                c = doc["channels"][ch]
                want = float(f"{c['terms'][term]['value'] * DATASHEET[c['kind']][term]:.3g}")
                assert f"{want:g} ({ch}" in label[0]
            if label and unit:
                assert any(f" {u}," in label[0] for u in unit)
    said = [t for f in figs for t in f["legends"][0][2]]
    assert any(t.startswith("bias instability B = ") for t in said)  # the data have a flicker floor


@pytest.mark.parametrize("grid", ["octave", "decade"])
def test_fitted_lines_stay_within_the_data_taus(rendered, grid: str, tmp_path: Path, monkeypatch) -> None:
    """On a decade grid the curve ends at m = 10^k while the fit's octave grid goes on to
    the next power of 2: the lines stop where the drawn curve does."""
    doc, figs = rendered
    if grid != "octave":
        data = write_rows(tmp_path / "imu.txt", thesis_like(1 << 15, 9))
        argv = ["analyze", str(data), "--fs", "100", "--no-warmup", "--no-model", "--taus", grid]
        doc, figs = _render(argv + ["--channels", "gx,gy,gz", "--plot", str(tmp_path / "figs")], monkeypatch)
        last = max(p["tau_s"] for p in doc["channels"]["gx"]["curve"] if p["dev"])
        assert doc["channels"]["gx"]["fit"]["tau_window_s"][1] > last * 1.2  # the case: a fit past the curve
    for f in figs:
        if not f["name"].startswith("adev_"):
            continue
        for a in f["axes"]:
            if not a["title"]:
                continue  # the residual panels: data points only
            pts = [p["tau_s"] for p in doc["channels"][a["title"]]["curve"] if p["dev"] and not p.get("flags")]
            lo, hi = min(pts), max(pts)
            assert a["lines"], a["title"]
            for x0, x1, style, marker in a["lines"]:
                assert lo * (1 - 1e-9) <= x0 and x1 <= hi * (1 + 1e-9), (a["title"], x0, x1, lo, hi, style, marker)


def test_flagged_long_taus_end_the_fitted_lines(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A device log whose last levels are flagged (sat): those points are drawn as
    crosses, not fitted, and no fitted line goes past the last point that is."""
    rng = np.random.default_rng(4)
    n = 1 << 14
    codes = np.clip(
        np.rint(512 + 2.0 * rng.standard_normal((n, 7)) + np.cumsum(0.05 * rng.standard_normal((n, 7)), 0)), 0, 1023
    )

    def sat(ch, level, pairs, acc, flags):
        return (pairs, acc, 1) if level >= 10 else (pairs, acc, flags)

    log = tmp_path / "dev.log"
    log.write_bytes(b"".join(report_lines(codes.astype(int), 13, tweak=sat, extra=",mode=allan,range=1.5")))
    doc, figs = _render(["analyze", str(log), "--no-model", "--plot", str(tmp_path / "figs")], monkeypatch)
    checked = 0
    for f in figs:
        for a in f["axes"]:
            if not a["title"]:
                continue
            curve = doc["channels"][a["title"]]["curve"]
            assert any(p.get("flags") for p in curve)
            hi = max(p["tau_s"] for p in curve if p["dev"] and not p.get("flags"))
            for _, x1, style, _ in a["lines"]:
                assert x1 <= hi * (1 + 1e-9), (a["title"], x1, hi, style)
                checked += 1
    assert checked >= 12
