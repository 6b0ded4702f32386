"""The ``imu-allan dynamic`` command: windowed Allan deviation over time, the
warm-up and stationarity (dynamic.py), in text, JSON, CSV and a heat map."""
from __future__ import annotations

import argparse
import sys
from typing import Any, Callable, Optional

from .errors import InputError

MEMORY = 1 << 30
"""Bytes of float64 samples the raw windows may hold (the default of analyze's --memory)."""


def add_subcommands(sub: Any) -> dict[str, Callable[[argparse.Namespace], int]]:
    from .cliargs import _channel_list, _fs
    p = sub.add_parser(
        "dynamic", help="Allan deviation window by window: is the sensor settled? (warm-up, stationarity)",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Split a recording into windows of time and compute the Allan deviation in\n"
            "each, to see whether the sensor was settled the whole time:\n"
            "  - a device log with periodic reports ('interval'): each report minus the\n"
            "    one before it is the EXACT non-overlapping Allan variance of the pairs\n"
            "    completed between them (the device's sums are cumulative); a report lost\n"
            "    on the radio makes one window longer; a reset starts over (the last run\n"
            "    is used);\n"
            "  - a raw capture, rows file or CSV: sliding windows (--window, --step), the\n"
            "    overlapping estimator.\n"
            "Each window's deviation at each tau is tested against the pooled rest of the\n"
            "record (F test with Greenhall's degrees of freedom); a window 'departs' when\n"
            "some tau lies beyond its interval, at --level confidence per channel over all\n"
            "windows and taus together. The warm-up is the leading stretch of departing\n"
            "windows; departures after it make the channel non-stationary (with the taus\n"
            "affected). Deviations are in the input's units (ADC counts for codes)."),
        epilog=(
            "examples:\n"
            "  imu-allan dynamic device.log                    # windows from the reports\n"
            "  imu-allan dynamic imu.txt --fs 100 --window 300 --plot dyn.png\n"
            "  imu-allan dynamic device.log --json             # see docs/dynamic.md\n\n"
            "exit status: 0 success, 2 usage or input error (one line on stderr)"))
    p.add_argument("file", metavar="FILE", help="device log, capture, rows file or CSV")
    p.add_argument("--fs", type=_fs, metavar="HZ", help="sample rate of a rows file or CSV without time column")
    p.add_argument("--from", dest="source", choices=("auto", "reports", "samples"), default="auto",
                   help="windows from the device's reports or from the samples (default: the reports "
                        "of a device log, the samples of a capture, rows file or CSV)")
    p.add_argument("--window", type=_positive_seconds, metavar="S",
                   help="raw samples: window length, s (default: a sixteenth of the record)")
    p.add_argument("--step", type=_positive_seconds, metavar="S",
                   help="raw samples: windows start every S seconds (default: half a window)")
    p.add_argument("--level", type=_level, default=0.95, metavar="P",
                   help="confidence of the departure test per channel, 0.5-0.9999 (default 0.95)")
    p.add_argument("--channels", type=_channel_list, metavar="LIST", help="channels, e.g. gx,gy,gz")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--json", action="store_true", help="print the windows as JSON (docs/dynamic.md)")
    g.add_argument("--csv", action="store_true", help="print one CSV line per window, channel and tau")
    p.add_argument("--plot", metavar="PNG", help="write the heat map of ADEV(t, tau) / ADEV(whole) to PNG")
    return {"dynamic": cmd_dynamic}


def _positive_seconds(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not (v > 0 and v < 1e9):
        raise argparse.ArgumentTypeError(f"must be above 0 s: {text!r}")
    return v


def _level(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a probability: {text!r}") from None
    if not 0.5 <= v <= 0.9999:
        raise argparse.ArgumentTypeError(f"must be within 0.5-0.9999: {text!r}")
    return v


def load_windows(path: str, source: str = "auto", fs: Optional[float] = None,
                 channels: Optional[list[str]] = None, window_s: Optional[float] = None,
                 step_s: Optional[float] = None) -> tuple[Any, list[str]]:
    """The windows of ``path`` (dynamic.Windows) and notes about the choice."""
    from .sources import load
    return windows_of(load(path), path, source, fs, channels, window_s, step_s)


def windows_of(src: Any, path: str, source: str = "auto", fs: Optional[float] = None,
               channels: Optional[list[str]] = None, window_s: Optional[float] = None,
               step_s: Optional[float] = None) -> tuple[Any, list[str]]:
    """``load_windows`` for a source already loaded (sources.load)."""
    import numpy as np
    from . import dynamic
    from .channels import CHANNELS
    from .device.records import decode_bytes
    notes: list[str] = []
    reports = []
    # a device log (no samples) is read again for all its reports; a capture's
    # samples are used unless the reports are asked for (it is read once)
    if (source == "reports" or (source == "auto" and src.samples is None)) and path != "-":
        with open(path, "rb") as f:
            reports = decode_bytes(f.read()).reports
    runs = dynamic.runs(reports)
    use_reports = source == "reports" or (source == "auto" and runs and len(runs[-1]) >= 2)
    if use_reports:
        if not runs:
            raise InputError(f"'{src.name}': no complete device report in it")
        if len(runs) > 1:
            notes.append(f"{len(runs)} runs (a reset between reports): the last one used, "
                         f"{len(runs[-1])} reports")
        chans = [c for c in CHANNELS if channels is None or c in channels]
        return dynamic.from_reports(runs[-1], chans), notes
    if src.samples is None:
        raise InputError(f"'{src.name}': a single device report and no samples: nothing to split in "
                         "windows (record with periodic reports: 'interval 60')")
    rate = src.samples.fs or fs or (float(src.report.header.fs_hz) if src.report else None)
    if rate is None:
        raise InputError("the sample rate is unknown: give --fs HZ")
    sel = [i for i, c in enumerate(src.samples.channels) if channels is None or c in channels]
    blocks, size = [], 0
    for b in src.samples.open_blocks():
        blocks.append(b[sel])
        size += b.shape[1] * len(sel) * 8
        if size > MEMORY:
            raise InputError(f"'{src.name}': more than {MEMORY >> 20} MB of samples: too large for "
                             "windows in memory (cut the file, or record with periodic device reports)")
    data = np.concatenate(blocks, axis=1).astype(np.float64)
    temp = None
    if src.samples.open_temperature is not None:
        temp = np.concatenate(list(src.samples.open_temperature())).astype(np.float64).ravel()
    if data.shape[1] < 64:
        raise InputError(f"'{src.name}': {data.shape[1]} samples: too few for windows")
    chans = [src.samples.channels[i] for i in sel]
    return dynamic.from_samples(data, rate, chans, window_s, step_s, temp), notes


def cmd_dynamic(args: argparse.Namespace) -> int:
    from . import __version__, dynamic, dynamic_render
    ws, notes = load_windows(args.file, args.source, args.fs, args.channels, args.window, args.step)
    verdict = dynamic.assess(ws, args.level)
    doc = dynamic_render.build_doc(ws, verdict, args.file, f"imu-allan dynamic {__version__}", notes)
    if args.plot:
        try:
            dynamic_render.plot(doc, args.plot)
        except OSError as exc:
            raise InputError(f"cannot write '{args.plot}': {exc.strerror or exc}") from None
        print(f"imu-allan dynamic: wrote {args.plot}", file=sys.stderr)
    if args.json:
        from .render import to_json
        sys.stdout.write(to_json(doc))
    elif args.csv:
        sys.stdout.write(dynamic_render.csv(doc))
    else:
        sys.stdout.write(dynamic_render.text(doc))
    return 0
