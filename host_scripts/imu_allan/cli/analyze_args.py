"""The options and --help text of ``imu-allan analyze``, grouped by job: what
to read, how to analyze it, what to write."""

from __future__ import annotations

import argparse
from typing import Any

from .argtypes import _channel_list, _fs, _megabytes, _nonnegative_seconds, _positive_int, _seconds

OUTLIERS_HELP = (
    "spikes and bursts (a knock on the bench), found on the sample-to-sample jumps: "
    "replace (default; by the line between their neighbours, so they stay out of the "
    "statistics; the summary says how much N and B would move) or keep (counted and "
    "listed only); a recording that is mostly spikes is refused unless kept"
)


ANALYZE_DESCRIPTION = (
    "Characterize an IMU from a recording at rest. FILE is any of (found by content):\n"
    "  - a device log (imu-allan sim / monitor): the on-device Allan results;\n"
    "  - a raw capture or rows file (thesis rows: 7 ADC codes per line);\n"
    "  - a CSV with a header naming the columns (t, ax, ..., gz; also acc_x,\n"
    "    gyro_x, ...; units in brackets like 'gx [rad/s]' are used), EuRoC\n"
    "    imu0/data.csv, Kalibr's IMU CSV, 'rostopic echo -p' output;\n"
    "  - a ROS 1 bag, a ROS 2 bag (folder, .db3 or .mcap): sensor_msgs/Imu;\n"
    "  - a NumPy .npy / .npz array (column convention: docs/formats.md).\n\n"
    "It computes, in float64: the overlapping Allan deviation (and the\n"
    "non-overlapping one the device computes, modified Allan and Hadamard\n"
    "deviations) with 95 % confidence intervals (Greenhall's equivalent\n"
    "degrees of freedom, NIST SP 1065); fits the IEEE 952 noise terms to the\n"
    "whole curve, each with an interval and the tau range where it dominates,\n"
    "saying plainly when a term is not identifiable from the data:\n"
    "  N random walk (ARW / VRW)   B bias instability   K rate random walk\n"
    "  Q quantization              R rate ramp\n"
    "plus the PSD (Welch), and the thesis' noise model (Gauss-Markov bias +\n"
    "rate random walk + white noise) simulated from the terms, with its FIT%.\n"
    "Given a device log too (--device, or a capture in mode 'both'), the\n"
    "device's points are checked against the host's curve.\n\n"
    "Units: rates in m/s^2 (accelerometers) and deg/s (gyros). In --json, with u\n"
    "the rate unit: Q in u*s, N in u*sqrt(s), B in u, K in u/sqrt(s), R in u/s;\n"
    "the table also shows deg/sqrt(h), deg/h, m/s/sqrt(h), ug ... The thesis\n"
    "profile converts ADC codes (MMA7260Q at --range, LISY300AL, Vref 3.3 V);\n"
    "--scale gives your own sensor's scale per channel. Every conversion is\n"
    "written out in docs/analysis.md."
)

ANALYZE_EPILOG = (
    "examples:\n"
    "  imu-allan analyze device.log                      # on-device results only\n"
    "  imu-allan analyze imu.txt --fs 100 --brief        # the answer: N, B, K per channel\n"
    "  imu-allan analyze imu.txt --fs 100 --device device.log --plot figs/\n"
    "  imu-allan analyze log.csv --scale gx=1rad/s,gy=1rad/s,gz=1rad/s --json\n"
    "  imu-allan analyze run.bag --topic /imu0 --kalibr imu.yaml  # ROS 1 or 2 bag\n"
    "  imu-allan analyze imu.txt --fs 100 --kalibr imu.yaml --imu-utils imu_param.yaml\n"
    "  imu-allan analyze imu.txt --fs 100 --noise overbound --openvins imu0.yaml --vins vins.yaml\n\n"
    "exit status: 0 success, 2 usage, input or output error (one line on stderr)"
)


def add_analyze(sub: Any) -> None:
    p = sub.add_parser(
        "analyze",
        help="noise analysis: Allan deviations, IEEE 952 noise terms, PSD, Kalibr YAML",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=ANALYZE_DESCRIPTION,
        epilog=ANALYZE_EPILOG,
    )
    p.add_argument(
        "file", metavar="FILE", help="device log, capture, rows file, CSV, ROS bag or .npy/.npz (- for stdin)"
    )
    add_analyze_input(p.add_argument_group("what to read"))
    add_analyze_method(p.add_argument_group("how to analyze"))
    add_analyze_output(p.add_argument_group("what to write"))


def add_analyze_input(p: Any) -> None:
    """What to read and how to turn it into rates: file, rate, units, channels."""
    from ..profiles import PROFILES, RANGES

    p.add_argument(
        "--fs",
        type=_fs,
        metavar="HZ",
        help="sample rate, Hz: required for rows files and CSV without a time column (a device log's header, "
        "a time column or a bag's stamps give it; --fs contradicting them is an error)",
    )
    p.add_argument(
        "--topic", metavar="TOPIC", help="the sensor_msgs/Imu topic of a ROS bag holding several (e.g. /imu0)"
    )
    p.add_argument(
        "--profile",
        choices=PROFILES,
        help="unit conversion: thesis (the thesis board, default for ADC codes) or counts (no conversion)",
    )
    p.add_argument(
        "--scale",
        action="append",
        default=[],
        metavar="CH=VALUE[UNIT]",
        help="your sensor's scale: rate units per count (or per CSV unit), e.g. gx=0.0175 "
        "(deg/s), gx=1rad/s, ax=0.0039g; repeat or separate with commas; channels "
        "without one stay in counts (or keep the --profile's scale)",
    )
    p.add_argument(
        "--range",
        choices=RANGES,
        metavar="G",
        help="thesis accelerometer range in g (1.5, 2, 4, 6) when the device header does not say (default 1.5)",
    )
    p.add_argument(
        "--device", metavar="LOG", help="device log of the same run: its on-device results are overlaid and checked"
    )
    p.add_argument(
        "--channels", type=_channel_list, metavar="LIST", help="channels to analyze, e.g. gx,gy,gz (default all)"
    )
    p.add_argument(
        "--skip",
        type=_nonnegative_seconds,
        metavar="SECONDS",
        help="leave out the first SECONDS of the record (a warm-up); a device log alone is cut "
        "at its first report after them (its report minus that one)",
    )


def add_analyze_method(p: Any) -> None:
    """How to analyze: tau grid, warm-up test, outliers, model, memory."""
    from ..stats import TAU_KINDS

    p.add_argument(
        "--taus",
        choices=TAU_KINDS,
        default="octave",
        help="tau grid of the host's curves: octave (default; m = 1, 2, 4 ...), decade "
        "(1, 2, 4, 10 ...), log (10 per decade) or all (every m; slow)",
    )
    p.add_argument("--no-model", action="store_true", help="skip the thesis model's simulation and FIT%% (faster)")
    p.add_argument(
        "--no-warmup",
        action="store_true",
        help="do not test the record's windows for a warm-up (see imu-allan dynamic)",
    )
    p.add_argument(
        "--seed", type=_positive_int, default=1, metavar="S", help="random seed of the model simulation (default 1)"
    )
    p.add_argument("--outliers", choices=("replace", "keep"), default="replace", help=OUTLIERS_HELP)
    p.add_argument(
        "--memory",
        type=_megabytes,
        default=256,
        metavar="MB",
        help="samples kept in memory, as float64 (default 256 MB: 5.6e6 rows of six channels); "
        "larger files are streamed through temporary files, in bounded memory, with the same "
        "octave Allan deviations, PSD, outliers and model; MDEV, HDEV and other --taus grids "
        "need the samples in memory",
    )
    p.add_argument(
        "--quiet",
        action="store_true",
        help="no progress line on stderr (it shows only on a terminal, for work over a second)",
    )
    p.add_argument(
        "--horizon",
        type=_seconds,
        metavar="SECONDS",
        help="longest tau the over-bounding N + K pair covers (default 100 s, or a tenth of "
        "the record when shorter); see --noise",
    )
    p.add_argument(
        "--noise",
        choices=("fitted", "overbound"),
        default="fitted",
        help="the N and K written to --kalibr, --openvins and --vins: fitted (default: the IEEE 952 "
        "terms) or overbound (the smallest white + random-walk pair whose Allan deviation covers "
        "the measured curve's 95 %% upper limit up to --horizon: a principled inflation)",
    )


def add_analyze_output(p: Any) -> None:
    """What to write: the text (whole or --brief), JSON or CSV, and files."""
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--json", action="store_true", help="print the analysis as JSON (a stable interface, see docs/analysis.md)"
    )
    g.add_argument("--csv", action="store_true", help="print the noise terms as CSV")
    g.add_argument(
        "--brief", action="store_true", help="print only the first table: each channel's noise terms and intervals"
    )
    p.add_argument("--curves", metavar="FILE", help="write every curve (tau, deviation, interval, EDF) as CSV")
    p.add_argument("--plot", metavar="DIR", help="write PNG figures (Allan deviation, PSD) to DIR")
    p.add_argument(
        "--kalibr", metavar="FILE", help="write a Kalibr imu.yaml (continuous-time noise densities and random walks)"
    )
    p.add_argument(
        "--imu-utils", metavar="FILE", help="write an imu_utils-style YAML (gyr_n, gyr_w, acc_n, acc_w, per axis)"
    )
    p.add_argument(
        "--openvins",
        metavar="FILE",
        help="write OpenVINS' imu0: block (kalibr_imu_chain.yaml; continuous-time N and K, worst axis)",
    )
    p.add_argument(
        "--vins",
        metavar="FILE",
        help="write VINS-Fusion's acc_n gyr_n acc_w gyr_w (discrete-time standard deviations at the rate measured)",
    )
