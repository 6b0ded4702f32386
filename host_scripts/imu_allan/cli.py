"""The ``imu-allan`` command line."""
from __future__ import annotations

import argparse
import os
import sys
from typing import Any, NoReturn, Optional

from . import CHANNELS, __version__
from .errors import InputError

EPILOG_EXIT = "exit status: 0 success, 1 {one}, 2 usage or input error (one line on stderr)"


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit 2)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def _fs(text: str) -> float | int:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (v > 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a positive number of Hz: {text!r}")
    return int(v) if v.is_integer() else v


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"must not be negative: {text}")
    return v


def _count(text: str) -> int:
    """A row count: 100000, or 1e6."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a count: {text!r}") from None
    if not (v >= 0 and v.is_integer()):
        raise argparse.ArgumentTypeError(f"must be a whole number of rows: {text!r}")
    return int(v)


def _baud(text: str) -> int:
    v = _positive_int(text)
    if v == 0:
        raise argparse.ArgumentTypeError("must be a positive number of baud")
    return v


def _seconds(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (v > 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds: {text!r}")
    return v


def _levels(text: str) -> int:
    v = _positive_int(text)
    if not 1 <= v <= 32:
        raise argparse.ArgumentTypeError("must be 1..32")
    return v


def _read_bytes(path: str) -> bytes:
    if path == "-":
        return sys.stdin.buffer.read()
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError as exc:
        raise InputError(f"cannot read '{path}': {exc.strerror or exc}") from None


def _add_format(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--json", action="store_true",
                   help="print JSON: {header, rows, errors} (a stable interface for scripts)")
    g.add_argument("--csv", action="store_true", help="print CSV, one line per row, with a header line")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="imu-allan",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Host tools for imu-allan. The firmware on the IMU board computes, for\n"
            "each sensor channel (ax ay az gx gy gz) and each cluster size\n"
            "m = 1, 2, 4, ... (octave 'levels'), the exact integer sum behind the\n"
            "non-overlapping Allan variance, and sends it over the serial link in\n"
            "the format of docs/protocol.md. These tools read those logs, compute\n"
            "the same statistic on the host, compare both, and make test data."),
        epilog=(
            "typical session:\n"
            "  imu-allan gen -n 200000 --seed 1 -o imu.txt      # synthetic IMU rows\n"
            "  imu-allan sim --adc imu.txt -o device.log        # run the firmware on them\n"
            "  imu-allan decode device.log                      # the device's Allan table\n"
            "  imu-allan reference imu.txt --fs 100             # the same, computed on the host\n"
            "  imu-allan check device.log imu.txt               # do they agree exactly?\n"
            "  imu-allan analyze imu.txt --fs 100 --device device.log --plot figs/\n"
            "                                                   # noise terms, intervals, plots\n\n"
            "with the board on a serial port:\n"
            "  imu-allan monitor --port /dev/ttyUSB0            # live view, all logged to a file\n"
            "  imu-allan cmd --port /dev/ttyUSB0 mode raw       # one command, prints its reply\n"
            "  imu-allan rows capture.log -o imu.txt            # raw/binary capture -> rows file\n\n"
            "Units: Allan variance in ADC counts^2 (deviation in counts), tau in\n"
            "seconds. Run 'imu-allan COMMAND --help' for a command's options."),
    )
    parser.add_argument("--version", action="version", version=f"imu-allan {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    from .cli_thesis import add_subcommands  # sweep, thermal (issue 15)
    COMMANDS.update(add_subcommands(sub))

    p = sub.add_parser(
        "decode", help="print the Allan table of a device log",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Read a log of what the device sent (any bytes: a serial capture,\n"
            "garbage and all) and print its last complete report: the header\n"
            "(firmware, sample rate fs, samples n, drops, clips, temperature,\n"
            "reset cause) and one row per channel and level with tau = m/fs,\n"
            "pairs, avar = acc / (2 m^2 pairs) and adev = sqrt(avar) in counts,\n"
            "and flags (sat: the accumulator saturated, the value is a lower\n"
            "bound; range: too wide a code range to be exact at that level).\n\n"
            "Only intact lines (CRC checked) of complete reports are used. Lines\n"
            "with a bad CRC, cut short, malformed or out of place are counted and\n"
            "listed at the end, never used."),
        epilog=EPILOG_EXIT.format(one="no complete report in the log"))
    p.add_argument("log", metavar="LOG", help="device log file, or - for stdin")
    _add_format(p)
    p.add_argument("--all", action="store_true", help="every complete report, not only the last")

    p = sub.add_parser(
        "reference", help="compute the Allan table of a rows file on the host (float64)",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Compute the non-overlapping Allan variance at m = 1, 2, 4, ...\n"
            "of a rows file, independently of the firmware, in float64 (cluster\n"
            "sums are exact integers). Output has the same table, JSON and CSV\n"
            "shape as 'decode'; 'acc' is the exact integer the device would send.\n\n"
            "Rows file (thesis format): one sample set per line, 7 integer codes\n"
            "0..1023 separated by tabs or spaces: ax ay az gx gy gz temp.\n"
            "'#' starts a comment; blank lines are ignored."),
        epilog="exit status: 0 success, 2 usage or input error (one line on stderr)")
    p.add_argument("file", metavar="FILE", help="rows file, or - for stdin")
    p.add_argument("--fs", type=_fs, required=True, metavar="HZ", help="sample rate of the rows, Hz")
    p.add_argument("--levels", type=_levels, default=15, metavar="L",
                   help="octave levels, m = 1 .. 2^(L-1) (default 15, the ATmega168 firmware's)")
    _add_format(p)

    p = sub.add_parser(
        "check", help="compare a device log with the reference computed from the same rows",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Check the last complete report of LOG against FILE, the rows the\n"
            "device sampled (e.g. the --adc input of 'imu-allan sim'). Each device\n"
            "row covers exactly the first (pairs+1)*m rows of FILE; for each one\n"
            "the host recomputes, over exactly those rows, the exact integer sum\n"
            "(must equal the device's acc bit for bit) and the float64 Allan\n"
            "variance (must agree within 1e-12 relative). Flagged rows (sat,\n"
            "range) are listed, not compared; a sat row's exact sum must reach\n"
            "its acc (the saturation value).\n"
            "The header must show no drops and at most as many samples as FILE."),
        epilog=EPILOG_EXIT.format(one="any mismatch, or no complete report"))
    p.add_argument("log", metavar="LOG", help="device log file (- for stdin)")
    p.add_argument("file", metavar="FILE", help="rows file the device sampled (- for stdin)")
    p.add_argument("--fs", type=_fs, metavar="HZ",
                   help="expected sample rate: a report with another fs is a mismatch")

    from .gen import HELP, KINDS, PROFILES, UNITS
    p = sub.add_parser(
        "gen", help="write a synthetic IMU rows file (thesis noise model)",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Write N rows of synthetic 10-bit ADC codes (ax ay az gx gy gz temp)\n"
            "in the thesis format, from the thesis noise model, per channel:\n"
            "  code = clip(round(offset + white noise + Gauss-Markov bias\n"
            "                    + rate random walk + drift * t), 0, 1023)\n"
            "Defaults (--profile thesis) resemble the thesis board at rest.\n"
            "The same seed and parameters always give the same file; the first\n"
            "lines are '#' comments with the command that reproduces it.\n\n"
            "Noise parameters take a number (every channel) or a list such as\n"
            "'gx=0.9,gy=0.6' (channels not named keep their default). Units:\n"
            + "".join(f"  --{k.replace('_', '-'):<9} {v}\n" for k, v in UNITS.items()) +
            "\nKinds (--kind):\n"
            "  noise   the noise model above (default)\n"
            "  walk    random walks (rrw 2 counts/step) reflected at 0 and 1023\n"
            "  drift   the noise model plus linear drifts of a few hundredths count/s\n"
            "  clip    mid-scale with white noise of 400 counts: hits 0 and 1023 often\n"
            "  square  full-scale square waves 0/1023, half period 1, 2, 4 .. 32\n"
            "          samples for ax .. gz (noise parameters unused)"),
        epilog="exit status: 0 success, 2 usage or input error")
    p.add_argument("-n", type=_count, default=100_000, metavar="N", help="rows (default 100000)")
    p.add_argument("--fs", type=_fs, default=100, metavar="HZ", help="sample rate, Hz (default 100)")
    p.add_argument("--seed", type=_positive_int, default=1, metavar="S", help="random seed (default 1)")
    p.add_argument("--kind", choices=KINDS, default="noise", help="kind of stream (default noise)")
    p.add_argument("--profile", choices=PROFILES, default="thesis", help="default parameters")
    for name, text in HELP.items():
        p.add_argument(f"--{name.replace('_', '-')}", metavar="SPEC", help=text)
    p.add_argument("--json-params", metavar="PFILE", help="also write the exact parameters used, as JSON")
    p.add_argument("--model", metavar="MFILE", help="rows of the continuous sensor model (JSON, docs/thesis-questions.md) at the ADC's instants")
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="rows file to write (- for stdout)")

    p = sub.add_parser(
        "sim", help="run the firmware in the simulator on a rows file",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Run the firmware (an AVR ELF) in the simulator harness imu-sim, its\n"
            "ADC fed from a rows file, and write what the device sent to LOG.\n"
            "Nothing is built here: 'make' builds the firmware, 'make sim' the\n"
            "harness. The harness is $IMU_SIM, else build/host/imu-sim of this\n"
            "checkout, else imu-sim on PATH. Its exit status is returned."),
        epilog="then: imu-allan decode LOG, imu-allan check LOG FILE")
    p.add_argument("--adc", metavar="FILE", help="rows file the ADC reads (or --model)")
    p.add_argument("--model", metavar="MFILE", help="feed the ADC from the sensor model instead: --seconds S of it at --fs")
    p.add_argument("--seconds", type=_seconds, default=60.0, metavar="S", help="with --model (default 60)")
    p.add_argument("--fs", metavar="HZ", help="sample rate to set on the device, Hz")
    p.add_argument("--uart-in", metavar="FILE", help="commands to send to the device")
    p.add_argument("--firmware", metavar="ELF",
                   help="firmware ELF (default build/avr-atmega168/imu-allan.elf)")
    p.add_argument("--stats", nargs="?", const=True, metavar="SFILE",
                   help="ask the harness for run statistics (to SFILE if given)")
    p.add_argument("-o", "--output", required=True, metavar="LOG", help="device log to write")

    p = sub.add_parser(
        "rows", help="turn a raw or binary capture into a rows file",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Read a capture of the device in output mode raw, binary or both (any\n"
            "bytes: e.g. the log of 'imu-allan monitor') and write the samples it\n"
            "holds as a rows file (thesis format: 7 tab-separated codes per line,\n"
            "ax ay az gx gy gz temp), as 'imu-allan reference' and\n"
            "'imu-allan sim --adc' read it.\n\n"
            "Raw rows must be whole lines of exactly 7 codes 0..1023; the first,\n"
            "usually partial, line of a capture is never used. Binary frames are\n"
            "used only when their CRC checks. Count lines ($C,<rows>, every 100\n"
            "rows) tell how many rows were lost on the way; frame sequence\n"
            "numbers tell how many frames were. Replies and reports in between are\n"
            "skipped. A summary line goes to stderr: rows written, bad rows (whole\n"
            "lines that are not valid rows), rows lost (per count lines), frames\n"
            "lost (per sequence numbers) and bad frames (CRC failed). Damaged data\n"
            "is never written: what cannot be checked is left out."),
        epilog=EPILOG_EXIT.format(one="rows or frames were lost or bad, or none were found "
                                      "(the file is still written)"))
    p.add_argument("log", metavar="LOG", help="capture file, or - for stdin")
    p.add_argument("-o", "--output", required=True, metavar="FILE",
                   help="rows file to write (- for stdout)")

    p = sub.add_parser(
        "monitor", help="live view of a device on a serial port (and log everything)",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Open the serial port and show, refreshed in place, the latest complete\n"
            "report: its header (fs, n, drops, clips, mode, range, ...) and the\n"
            "Allan deviation table in ADC counts (one line per tau, one column per\n"
            "channel; '!' marks a flagged value). Below it: the samples received\n"
            "in raw and binary modes (rows/s, rows and frames lost), counts of bad\n"
            "lines, and the last replies. When stdout is not a terminal, each new\n"
            "report and reply is printed once instead.\n\n"
            "Every byte received is appended, as is, to the log file, which\n"
            "'imu-allan decode' and 'imu-allan rows' read back. When stdin is a\n"
            "terminal, a line typed and ended with Enter is sent as a command\n"
            "(e.g. status, mode raw, rate 250, report). Ctrl-C quits."),
        epilog=("exit status: 0 on Ctrl-C (or, with --once, after a report), 1 the port "
                "was lost, 2 usage error or the port cannot be opened"))
    p.add_argument("--port", required=True, metavar="PORT", help="serial port, e.g. /dev/ttyUSB0")
    p.add_argument("--baud", type=_baud, default=115200, metavar="B",
                   help="baud rate (default 115200, the firmware's default BAUD)")
    p.add_argument("--log", metavar="FILE",
                   help="file to append everything received to "
                        "(default imu-allan-YYYYmmdd-HHMMSS.log here)")
    p.add_argument("--once", action="store_true",
                   help="exit after the first complete report (for scripts)")

    p = sub.add_parser(
        "cmd", help="send one command to the device and print its reply",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Send WORDS, joined by spaces, as one command line to the device and\n"
            "print its reply ('ok ...' or 'error:<code> <reason>'); whatever else\n"
            "the device sends meanwhile (reports, raw rows, binary frames) is\n"
            "ignored. Commands (docs/protocol.md): help, status, report, reset,\n"
            "stop, start [count], rate <hz>, interval <s>, mode <allan|raw|binary|\n"
            "both>, range <1.5|2|4|6>, save, load, defaults.\n\n"
            "example: imu-allan cmd --port /dev/ttyUSB0 rate 250"),
        epilog="exit status: 0 reply ok, 1 error reply or no reply in time, 2 usage error "
               "or the port cannot be opened")
    p.add_argument("--port", required=True, metavar="PORT", help="serial port, e.g. /dev/ttyUSB0")
    p.add_argument("--baud", type=_baud, default=115200, metavar="B", help="baud rate (default 115200)")
    p.add_argument("--timeout", type=_seconds, default=3.0, metavar="S",
                   help="seconds to wait for the reply (default 3; a command waits while "
                        "a report is being sent)")
    p.add_argument("words", nargs="+", metavar="WORDS", help="the command and its argument")

    _add_analyze(sub)
    return parser


def _megabytes(text: str) -> int:
    v = _positive_int(text)
    if v < 1:
        raise argparse.ArgumentTypeError("must be at least 1 MB")
    return v


def _add_analyze(sub: Any) -> None:
    from .allan import TAU_KINDS
    from .profiles import PROFILES, RANGES
    p = sub.add_parser(
        "analyze", help="noise analysis: Allan deviations, IEEE 952 noise terms, PSD, Kalibr YAML",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Characterize an IMU from a recording at rest. FILE is any of (found by content):\n"
            "  - a device log (imu-allan sim / monitor): the on-device Allan results;\n"
            "  - a raw capture or rows file (thesis rows: 7 ADC codes per line);\n"
            "  - a CSV with a header naming the columns (t, ax, ..., gz; also acc_x,\n"
            "    gyro_x, ...; units in brackets like 'gx [rad/s]' are used).\n\n"
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
            "written out in docs/analysis.md."),
        epilog=(
            "examples:\n"
            "  imu-allan analyze device.log                      # on-device results only\n"
            "  imu-allan analyze imu.txt --fs 100 --device device.log --plot figs/\n"
            "  imu-allan analyze log.csv --scale gx=1rad/s,gy=1rad/s,gz=1rad/s --json\n"
            "  imu-allan analyze imu.txt --fs 100 --kalibr imu.yaml --imu-utils imu_param.yaml\n\n"
            "exit status: 0 success, 2 usage or input error (one line on stderr)"))
    p.add_argument("file", metavar="FILE", help="device log, capture, rows file or CSV (- for stdin)")
    p.add_argument("--fs", type=_fs, metavar="HZ",
                   help="sample rate, Hz: required for rows files and CSV without a time column "
                        "(a device log's header gives it)")
    p.add_argument("--profile", choices=PROFILES,
                   help="unit conversion: thesis (the thesis board, default for ADC codes) or counts "
                        "(no conversion)")
    p.add_argument("--scale", action="append", default=[], metavar="CH=VALUE[UNIT]",
                   help="your sensor's scale: rate units per count (or per CSV unit), e.g. gx=0.0175 "
                        "(deg/s), gx=1rad/s, ax=0.0039g; repeat or separate with commas; channels "
                        "without one stay in counts (or keep the --profile's scale)")
    p.add_argument("--range", choices=RANGES, metavar="G",
                   help="thesis accelerometer range in g (1.5, 2, 4, 6) when the device header does "
                        "not say (default 1.5)")
    p.add_argument("--device", metavar="LOG",
                   help="device log of the same run: its on-device results are overlaid and checked")
    p.add_argument("--taus", choices=TAU_KINDS, default="octave",
                   help="tau grid of the host's curves: octave (default; m = 1, 2, 4 ...), decade "
                        "(1, 2, 4, 10 ...), log (10 per decade) or all (every m; slow)")
    p.add_argument("--channels", metavar="LIST", help="channels to analyze, e.g. gx,gy,gz (default all)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--json", action="store_true",
                   help="print the analysis as JSON (a stable interface, see docs/analysis.md)")
    g.add_argument("--csv", action="store_true", help="print the noise terms as CSV")
    p.add_argument("--curves", metavar="FILE", help="write every curve (tau, deviation, interval, EDF) as CSV")
    p.add_argument("--plot", metavar="DIR", help="write PNG figures (Allan deviation, PSD) to DIR")
    p.add_argument("--kalibr", metavar="FILE",
                   help="write a Kalibr imu.yaml (continuous-time noise densities and random walks)")
    p.add_argument("--imu-utils", metavar="FILE",
                   help="write an imu_utils-style YAML (gyr_n, gyr_w, acc_n, acc_w, per axis)")
    p.add_argument("--no-model", action="store_true",
                   help="skip the thesis model's simulation and FIT%% (faster)")
    p.add_argument("--seed", type=_positive_int, default=1, metavar="S",
                   help="random seed of the model simulation (default 1)")
    p.add_argument("--memory", type=_megabytes, default=1024, metavar="MB",
                   help="samples kept in memory for the non-octave statistics (default 1024 MB); "
                        "larger files are streamed: octave Allan deviations and PSD only")


# ---- commands -------------------------------------------------------------------


def _report_doc(rep: Any) -> dict[str, Any]:
    from .decode import flag_names
    from .report import row_dict
    fs = rep.header["fs_hz"]
    return {"header": rep.header,
            "rows": [row_dict(r.channel, r.level, r.pairs, r.acc, r.avar, fs, flag_names(r.flags))
                     for r in rep.rows]}


def cmd_decode(args: argparse.Namespace) -> int:
    from . import report as out
    from .decode import decode_bytes
    res = decode_bytes(_read_bytes(args.log))
    if not res.reports:
        lost = ", ".join(f"{k} {v}" for k, v in res.errors.items() if v) or "the log is empty"
        print(f"imu-allan decode: no complete report in '{args.log}' (not used: {lost})",
              file=sys.stderr)
        return 1
    docs = [_report_doc(r) for r in (res.reports if args.all else res.reports[-1:])]
    if args.json:
        if args.all:
            sys.stdout.write(out.to_json({"reports": docs, "errors": res.errors}))
        else:
            sys.stdout.write(out.to_json({**docs[0], "errors": res.errors,
                                          "complete_reports": len(res.reports)}))
    elif args.csv:
        sys.stdout.write(out.to_csv(docs, with_seq=args.all))
    else:
        total = len(res.reports)
        for i, d in enumerate(docs):
            which = f"{i + 1} of {total}" if args.all else (
                "the only complete report" if total == 1 else f"the last of {total} complete reports")
            sys.stdout.write(f"{args.log}: report seq {d['header']['seq']} ({which})\n")
            sys.stdout.write(out.device_header_text(d["header"]) + "\n")
            sys.stdout.write(out.table(d["rows"]) + "\n")
        sys.stdout.write(out.errors_text(res.errors))
    return 0


def cmd_reference(args: argparse.Namespace) -> int:
    from . import report as out
    from .reference import OctaveCascade
    from .rows import iter_blocks
    cascade = OctaveCascade(args.levels, len(CHANNELS))
    for block in iter_blocks(args.file):
        cascade.push(block[: len(CHANNELS)])
    pairs, acc, avar = cascade.pairs(), cascade.acc(), cascade.avar()
    rows = [out.row_dict(ch, k, int(pairs[k, c]), acc[k][c], float(avar[k, c]), args.fs)
            for c, ch in enumerate(CHANNELS) for k in range(args.levels)]
    header = {"source": "reference", "file": args.file, "fs_hz": args.fs, "levels": args.levels,
              "n": cascade.n}
    if args.json:
        sys.stdout.write(out.to_json({"header": header, "rows": rows, "errors": {}}))
    elif args.csv:
        sys.stdout.write(out.to_csv([{"header": header, "rows": rows}]))
    else:
        sys.stdout.write(f"{args.file}: float64 reference, n {cascade.n} rows "
                         f"({cascade.n / args.fs:.6g} s at {args.fs} Hz), levels {args.levels}\n\n")
        sys.stdout.write(out.table(rows))
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    from .check import check_report, summary
    from .decode import decode_bytes
    if args.log == "-" and args.file == "-":
        raise InputError("LOG and FILE cannot both be stdin")
    res = decode_bytes(_read_bytes(args.log))
    if not res.reports:
        print(f"imu-allan check: no complete report in '{args.log}'", file=sys.stderr)
        return 1
    rep = res.reports[-1]
    result = check_report(rep, args.file, args.fs)
    sys.stdout.write(summary(result, rep, args.log, args.file))
    return 0 if result.ok else 1


def cmd_gen(args: argparse.Namespace) -> int:
    if args.model:
        from .cli_thesis import gen_from_model
        return gen_from_model(args)
    from .gen import PARAMS, generate, make_params
    from .rows import format_rows
    params = make_params(n=args.n, fs_hz=args.fs, seed=args.seed, kind=args.kind,
                         profile=args.profile, **{p: getattr(args, p) for p in PARAMS})
    head = (f"# {params.command()}\n"
            f"# columns: {' '.join(params.channels)} (10-bit ADC codes), {params.fs_hz:g} Hz\n")
    try:
        f = sys.stdout.buffer if args.output == "-" else open(args.output, "wb")
    except OSError as exc:
        raise InputError(f"cannot write '{args.output}': {exc.strerror or exc}") from None
    try:
        f.write(head.encode())
        for block in generate(params):
            f.write(format_rows(block))
    finally:
        if f is not sys.stdout.buffer:
            f.close()
    if args.json_params:
        try:
            with open(args.json_params, "w") as jf:
                jf.write(params.to_json())
        except OSError as exc:
            raise InputError(f"cannot write '{args.json_params}': {exc.strerror or exc}") from None
    return 0


def cmd_sim(args: argparse.Namespace) -> int:
    if args.model or not args.adc:
        from .cli_thesis import sim_from_model
        return sim_from_model(args)
    from .simrun import run, sim_command
    return run(sim_command(args.adc, args.output, fs=args.fs, uart_in=args.uart_in,
                           firmware=args.firmware, stats=args.stats))


def _open_output(path: str) -> Any:
    if path == "-":
        return sys.stdout.buffer
    try:
        return open(path, "wb")
    except OSError as exc:
        raise InputError(f"cannot write '{path}': {exc.strerror or exc}") from None


def cmd_rows(args: argparse.Namespace) -> int:
    from .rows import BLOCK_BYTES, format_rows, open_input
    from .stream import LOSS_KEYS, StreamDecoder
    name = "<stdin>" if args.log == "-" else args.log
    src = open_input(args.log)
    dec = StreamDecoder()
    written = frames = 0
    try:
        dst = _open_output(args.output)
        try:
            dst.write(f"# imu-allan rows {name}\n"
                      f"# columns: ax ay az gx gy gz temp (10-bit ADC codes)\n".encode())
            while True:
                try:
                    block = src.read(BLOCK_BYTES)
                except OSError as exc:
                    raise InputError(f"cannot read '{name}': {exc.strerror or exc}") from None
                chunk = dec.feed(block) if block else dec.finish()
                if chunk.samples.shape[1]:
                    dst.write(format_rows(chunk.samples))
                    written += chunk.samples.shape[1]
                    frames += int(chunk.from_frame.sum())
                if not block:
                    break
        except OSError as exc:
            raise InputError(f"cannot write '{args.output}': {exc.strerror or exc}") from None
        finally:
            if dst is not sys.stdout.buffer:
                dst.close()
    finally:
        if src is not sys.stdin.buffer:
            src.close()
    c = dec.counts
    if written == 0:
        print(f"imu-allan rows: no raw rows or binary frames in '{name}' "
              f"(bad rows {c['bad_rows']}, bad frames {c['bad_frames']})", file=sys.stderr)
        return 1
    print(f"imu-allan rows: {written} rows written to {args.output} ({written - frames} from raw "
          f"rows, {frames} from binary frames); bad rows {c['bad_rows']}, rows lost "
          f"{c['rows_lost']} (count lines), frames lost {c['frames_lost']}, "
          f"bad frames {c['bad_frames']}", file=sys.stderr)
    return 1 if any(c[k] for k in LOSS_KEYS) else 0


def cmd_monitor(args: argparse.Namespace) -> int:
    from .monitor import run_monitor
    return run_monitor(args.port, args.baud, args.log, args.once)


def cmd_cmd(args: argparse.Namespace) -> int:
    from .monitor import PortError, command_line, open_port, send_command
    line = command_line(args.words)
    ser = open_port(args.port, args.baud)
    try:
        reply = send_command(ser, line, args.timeout)
    except PortError as exc:
        print(f"imu-allan cmd: {args.port}: connection lost ({exc})", file=sys.stderr)
        return 1
    finally:
        ser.close()
    if reply is None:
        print(f"imu-allan cmd: no reply from {args.port} within {args.timeout:g} s",
              file=sys.stderr)
        return 1
    print(reply)
    return 0 if reply.startswith("ok") else 1


def cmd_analyze(args: argparse.Namespace) -> int:
    from . import render
    from .analysis import Options, analyze, public
    from .profiles import build_profile, normalize_range, parse_scales
    from .sources import load
    scales = parse_scales(args.scale)
    src = load(args.file)
    device = None
    if args.device:
        dsrc = load(args.device)
        if dsrc.report is None:
            raise InputError(f"--device '{args.device}': no complete device report in it")
        device = dsrc.report
    header = (device or src.report).header if (device or src.report) is not None else None
    range_g = args.range
    if header is not None and header.get("range_g") is not None:
        hr = normalize_range(header["range_g"])
        if range_g is not None and normalize_range(range_g) != hr:
            raise InputError(f"--range {range_g} contradicts the device header (range={hr} g)")
        range_g = hr
    samples = src.samples
    if samples is not None and args.profile is None and (samples.units or not samples.integer):
        given = dict(scales)  # units named in a CSV header are used unless --scale says otherwise
        for ch, unit in samples.units.items():
            if ch not in given:
                try:
                    given.update(parse_scales([f"{ch}=1{unit}"]))
                except InputError:
                    raise InputError(f"'{src.name}': column {ch} has unit [{unit}], not a rate unit "
                                     "this tool knows (m/s^2, g, mg, deg/s, rad/s ...)") from None
        missing = [c for c in samples.channels if c not in given]
        if missing and not samples.integer:
            raise InputError(f"'{src.name}': the values are not 10-bit ADC codes, so the thesis scale "
                             f"does not apply: give the unit of {', '.join(missing)} with --scale "
                             f"(e.g. --scale {missing[0]}=1{'rad/s' if missing[0][0] == 'g' else 'm/s^2'}), "
                             "or --profile counts")
        scales = given
    profile = build_profile(args.profile, scales, range_g)
    chans = [c.strip() for c in args.channels.split(",")] if args.channels else None
    if chans:
        bad = [c for c in chans if c not in CHANNELS]
        if bad:
            raise InputError(f"--channels: unknown channel {bad[0]!r} (channels: {' '.join(CHANNELS)})")
    opts = Options(fs=args.fs, taus=args.taus, channels=chans, model=not args.no_model,
                   seed=args.seed, memory_budget=args.memory * 2**20)
    doc = public(analyze(src, profile, opts, device=device))
    written = []
    if args.curves:
        written.append(_write_text(args.curves, render.curves_csv(doc)))
    if args.kalibr:
        written.append(_write_text(args.kalibr, render.kalibr_yaml(doc)))
    if args.imu_utils:
        written.append(_write_text(args.imu_utils, render.imu_utils_yaml(doc)))
    if args.plot:
        from .plots import write_plots
        written += write_plots(doc, args.plot)
    if args.json:
        sys.stdout.write(render.to_json(doc))
    elif args.csv:
        sys.stdout.write(render.terms_csv(doc))
    else:
        sys.stdout.write(render.text(doc))
    for path in written:
        print(f"imu-allan analyze: wrote {path}", file=sys.stderr)
    return 0


def _write_text(path: str, text: str) -> str:
    try:
        with open(path, "w") as f:
            f.write(text)
    except OSError as exc:
        raise InputError(f"cannot write '{path}': {exc.strerror or exc}") from None
    return path


COMMANDS = {"analyze": cmd_analyze, "decode": cmd_decode, "reference": cmd_reference, "check": cmd_check,
            "gen": cmd_gen, "sim": cmd_sim, "rows": cmd_rows, "monitor": cmd_monitor,
            "cmd": cmd_cmd}


def main(argv: Optional[list[str]] = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    try:
        return COMMANDS[args.command](args)
    except InputError as exc:
        print(f"imu-allan {args.command}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1


if __name__ == "__main__":
    sys.exit(main())
