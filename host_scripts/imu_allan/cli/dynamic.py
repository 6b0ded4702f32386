"""The ``imu-allan dynamic`` command: windowed Allan deviation over time, the
warm-up and stationarity (dynamic.py), in text, JSON, CSV and a heat map."""

from __future__ import annotations

import argparse
import sys
from typing import Any, Callable

from ..errors import InputError

"""Bytes of float64 samples the raw windows may hold (the default of analyze's --memory)."""


def add_subcommands(sub: Any) -> dict[str, Callable[[argparse.Namespace], int]]:
    from .argtypes import _channel_list, _fs

    p = sub.add_parser(
        "dynamic",
        help="Allan deviation window by window: is the sensor settled? (warm-up, stationarity)",
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
            "windows and taus together. A warm-up is there when the first windows depart;\n"
            "it ends where the transient fitted over them is 95 % settled (a weak one\n"
            "departs for less time than it lasts); departures after it make the channel\n"
            "non-stationary (with the taus affected). Deviations are in the input's units\n"
            "(ADC counts for codes)."
        ),
        epilog=(
            "examples:\n"
            "  imu-allan dynamic device.log                    # windows from the reports\n"
            "  imu-allan dynamic imu.txt --fs 100 --window 300 --plot dyn.png\n"
            "  imu-allan dynamic device.log --json             # see docs/dynamic.md\n\n"
            "exit status: 0 success, 2 usage or input error (one line on stderr)"
        ),
    )
    p.add_argument("file", metavar="FILE", help="device log, capture, rows file or CSV")
    p.add_argument("--fs", type=_fs, metavar="HZ", help="sample rate of a rows file or CSV without time column")
    p.add_argument(
        "--from",
        dest="source",
        choices=("auto", "reports", "samples"),
        default="auto",
        help="windows from the device's reports or from the samples (default: the reports "
        "of a device log, the samples of a capture, rows file or CSV)",
    )
    p.add_argument(
        "--window",
        type=_positive_seconds,
        metavar="S",
        help="raw samples: window length, s (default: a sixteenth of the record)",
    )
    p.add_argument(
        "--step",
        type=_positive_seconds,
        metavar="S",
        help="raw samples: windows start every S seconds (default: half a window)",
    )
    p.add_argument(
        "--level",
        type=_level,
        default=0.95,
        metavar="P",
        help="confidence of the departure test per channel, 0.5-0.9999 (default 0.95)",
    )
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


def cmd_dynamic(args: argparse.Namespace) -> int:
    from .._version import __version__
    from ..analysis import dynamic
    from ..analysis.windows import load_windows
    from ..render import dynamic as dynamic_render

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
        from ..render.formats import to_json

        sys.stdout.write(to_json(doc))
    elif args.csv:
        sys.stdout.write(dynamic_render.csv(doc))
    else:
        sys.stdout.write(dynamic_render.text(doc))
    return 0
