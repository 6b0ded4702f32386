"""The ``imu-allan`` argument parser: every word, option and --help text
(main.py runs the commands). The value checkers are in argtypes.py, the
analyze command's options in analyze_args.py."""

from __future__ import annotations

import argparse
from typing import Any, Callable, Optional

from .._version import __version__
from ..channels import RATES_HZ
from .analyze_args import add_analyze
from .argtypes import (
    EPILOG_EXIT,
    EXIT_LOST,
    _add_format,
    _baud,
    _count,
    _device_rate,
    _fs,
    _levels,
    _Parser,
    _positive_int,
    _seconds,
)

__all__ = ["EXIT_LOST", "build_parser"]


def build_parser(more: Optional[Callable[[Any], None]] = None) -> argparse.ArgumentParser:
    """The whole command line; ``more(subparsers)`` may add subcommands (cli.py adds
    sweep and thermal from study.py)."""
    parser = _Parser(
        prog="imu-allan",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Host tools for imu-allan. The firmware on the IMU board computes, for\n"
            "each sensor channel (ax ay az gx gy gz) and each cluster size\n"
            "m = 1, 2, 4, ... (octave 'levels'), the exact integer sum behind the\n"
            "non-overlapping Allan variance, and sends it over the serial link in\n"
            "the format of docs/protocol.md. These tools read those logs, compute\n"
            "the same statistic on the host, compare both, and make test data."
        ),
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
            "seconds. Run 'imu-allan COMMAND --help' for a command's options."
        ),
    )
    parser.add_argument("--version", action="version", version=f"imu-allan {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    if more is not None:
        more(sub)
    _add_decode(sub)
    _add_reference(sub)
    _add_check(sub)
    _add_gen(sub)
    _add_sim(sub)
    _add_rows(sub)
    _add_monitor(sub)
    _add_cmd(sub)
    add_analyze(sub)
    return parser


def _add_decode(sub: Any) -> None:
    p = sub.add_parser(
        "decode",
        help="print the Allan table of a device log",
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
            "listed at the end, never used. The noise terms (T lines, the summary's\n"
            "terms rows) are held to the report's rows: one they contradict is left\n"
            "out, counted and said in a warning on stderr, as is a report whose seq\n"
            "goes backwards without a boot line (an older report replayed). Lines\n"
            "may end in LF, CR LF or CR."
        ),
        epilog=EPILOG_EXIT.format(one="no complete report in the log"),
    )
    p.add_argument("log", metavar="LOG", help="device log file, or - for stdin")
    _add_format(p)
    p.add_argument("--all", action="store_true", help="every complete report, not only the last")


def _add_reference(sub: Any) -> None:
    p = sub.add_parser(
        "reference",
        help="compute the Allan table of a rows file on the host (float64)",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Compute the non-overlapping Allan variance at m = 1, 2, 4, ...\n"
            "of a rows file, independently of the firmware, in float64 (cluster\n"
            "sums are exact integers). Output has the same table, JSON and CSV\n"
            "shape as 'decode'; 'acc' is the exact integer the device would send.\n\n"
            "Rows file (thesis format): one sample set per line, 7 integer codes\n"
            "0..1023 separated by tabs or spaces: ax ay az gx gy gz temp.\n"
            "'#' starts a comment; blank lines are ignored."
        ),
        epilog="exit status: 0 success, 2 usage, input or output error (one line on stderr)",
    )
    p.add_argument("file", metavar="FILE", help="rows file, or - for stdin")
    p.add_argument("--fs", type=_fs, required=True, metavar="HZ", help="sample rate of the rows, Hz")
    p.add_argument(
        "--levels",
        type=_levels,
        default=15,
        metavar="L",
        help="octave levels, m = 1 .. 2^(L-1) (default 15, the ATmega168 firmware's)",
    )
    _add_format(p)


def _add_check(sub: Any) -> None:
    p = sub.add_parser(
        "check",
        help="compare a device log with the reference computed from the same rows",
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
            "The header must show no drops and at most as many samples as FILE."
        ),
        epilog=EPILOG_EXIT.format(one="any mismatch, or no complete report"),
    )
    p.add_argument("log", metavar="LOG", help="device log file (- for stdin)")
    p.add_argument("file", metavar="FILE", help="rows file the device sampled (- for stdin)")
    p.add_argument("--fs", type=_fs, metavar="HZ", help="expected sample rate: a report with another fs is a mismatch")


def _add_gen(sub: Any) -> None:
    from ..noise.words import HELP, KINDS, PROFILES, UNITS

    p = sub.add_parser(
        "gen",
        help="write a synthetic IMU rows file (thesis noise model)",
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
            + "".join(f"  --{k.replace('_', '-'):<9} {v}\n" for k, v in UNITS.items())
            + "\nKinds (--kind):\n"
            "  noise   the noise model above (default)\n"
            "  walk    random walks (rrw 2 counts/step) reflected at 0 and 1023\n"
            "  drift   the noise model plus linear drifts of a few hundredths count/s\n"
            "  clip    mid-scale with white noise of 400 counts: hits 0 and 1023 often\n"
            "  square  full-scale square waves 0/1023, half period 1, 2, 4 .. 32\n"
            "          samples for ax .. gz (noise parameters unused)"
        ),
        epilog="exit status: 0 success, 2 usage, input or output error (one line on stderr)",
    )
    p.add_argument("-n", type=_count, default=100_000, metavar="N", help="rows (default 100000)")
    p.add_argument("--fs", type=_fs, default=100, metavar="HZ", help="sample rate, Hz (default 100)")
    p.add_argument("--seed", type=_positive_int, default=1, metavar="S", help="random seed (default 1)")
    p.add_argument("--kind", choices=KINDS, default="noise", help="kind of stream (default noise)")
    p.add_argument("--profile", choices=PROFILES, default="thesis", help="default parameters")
    for name, text in HELP.items():
        p.add_argument(f"--{name.replace('_', '-')}", metavar="SPEC", help=text)
    p.add_argument("--json-params", metavar="PFILE", help="also write the exact parameters used, as JSON")
    p.add_argument(
        "--model",
        metavar="MFILE",
        help="rows of the continuous sensor model (JSON, docs/thesis-questions.md) at the ADC's instants",
    )
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="rows file to write (- for stdout)")


def _add_sim(sub: Any) -> None:
    p = sub.add_parser(
        "sim",
        help="run the firmware in the simulator on a rows file",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Run the firmware (an AVR ELF) in the simulator harness imu-sim, its\n"
            "ADC fed from a rows file, and write what the device sent to LOG.\n"
            "Nothing is built here: 'make' builds the firmware, 'make sim' the\n"
            "harness. The harness is $IMU_SIM, else build/host/imu-sim of this\n"
            "checkout, else imu-sim on PATH. Its exit status is returned."
        ),
        epilog="then: imu-allan decode LOG, imu-allan check LOG FILE",
    )
    p.add_argument("--adc", metavar="FILE", help="rows file the ADC reads (or --model)")
    p.add_argument(
        "--model", metavar="MFILE", help="feed the ADC from the sensor model instead: --seconds S of it at --fs"
    )
    p.add_argument("--seconds", type=_seconds, default=60.0, metavar="S", help="with --model (default 60)")
    p.add_argument(
        "--fs",
        type=_device_rate,
        metavar="HZ",
        help=f"sample rate to set on the device, Hz: one of {', '.join(map(str, RATES_HZ))}",
    )
    p.add_argument("--uart-in", metavar="FILE", help="commands to send to the device")
    p.add_argument("--firmware", metavar="ELF", help="firmware ELF (default build/avr-atmega168/imu-allan.elf)")
    p.add_argument(
        "--stats", nargs="?", const=True, metavar="SFILE", help="ask the harness for run statistics (to SFILE if given)"
    )
    p.add_argument("-o", "--output", required=True, metavar="LOG", help="device log to write")


def _add_rows(sub: Any) -> None:
    p = sub.add_parser(
        "rows",
        help="turn a raw or binary capture into a rows file",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Read a capture of the device in output mode raw, binary or both (any\n"
            "bytes: e.g. the log of 'imu-allan monitor') and write the samples it\n"
            "holds as a rows file (thesis format: 7 tab-separated codes per line,\n"
            "ax ay az gx gy gz temp), as 'imu-allan reference' and\n"
            "'imu-allan sim --adc' read it.\n\n"
            "Raw rows must be whole lines of exactly 7 codes 0..1023; the first,\n"
            "usually partial, line of a capture is never used. Binary frames are\n"
            "used only when their CRC checks. Count lines ($C,<rows>,<drops>,<block>,\n"
            "every 100 rows or frames) tell how many were lost on the way, and\n"
            "their block CRC vouches for the bytes of the rows or frames since the\n"
            "previous count line: only verified blocks are written; a block whose\n"
            "CRC fails, or that lost or gained a line, is dropped whole, and rows\n"
            "no block CRC covers (after the last count line, before a restart no\n"
            "count line covers) are left out too. Captures of older firmware\n"
            "(count lines without a block CRC) and plain rows files are written\n"
            "as before, unverified, and the summary says so. Frame sequence numbers\n"
            "tell how many frames were lost. Replies and reports in between are\n"
            "skipped. A summary line goes to stderr: rows written, rows dropped\n"
            "(bad blocks, unverified), bad rows (whole lines that are not valid\n"
            "rows), rows lost (per count lines), frames lost, bad frames (CRC\n"
            "failed) and the sample sets the device itself lost (drops, per its\n"
            "count lines). Damaged data is never written: what cannot be checked\n"
            "is left out."
        ),
        epilog=EPILOG_EXIT.format(one="no rows or frames were found")
        + f", {EXIT_LOST} written, but rows or frames were lost or bad on the way (the summary "
        "line says how many)",
    )
    p.add_argument("log", metavar="LOG", help="capture file, or - for stdin")
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="rows file to write (- for stdout)")


def _add_monitor(sub: Any) -> None:
    p = sub.add_parser(
        "monitor",
        help="live view of a device on a serial port (and log everything)",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Open the serial port and show, on a full screen that fits the terminal\n"
            "(a line longer than the terminal is wrapped, never cut):\n"
            "  - a status line: the latest report's seq and age, the link's lines\n"
            "    received intact and damaged, the samples the device dropped and\n"
            "    those lost on the link, the sample rate in raw and binary modes;\n"
            "  - how much longer to record for +-10 % on the noise terms;\n"
            "  - the latest report: the device's own summary (the N and B lines\n"
            "    first, then its Allan deviation table in physical units), then\n"
            "    the header (fs, n, drops, clips, mode, range, ...) and the table\n"
            "    in ADC counts ('!' marks a flagged value); PgUp/PgDn scroll it;\n"
            "  - the conversation: each command sent and every line of its\n"
            "    reply, the last one shown whole while the terminal can hold it.\n"
            "When stdout is not a terminal, each new report and reply is printed\n"
            "once instead.\n\n"
            "Every byte received is appended, as is, to the log file, which\n"
            "'imu-allan decode' and 'imu-allan rows' read back. When stdin is a\n"
            "terminal, a line typed and ended with Enter is sent as a command\n"
            "(e.g. status, mode raw, rate 250, report); Backspace edits, Esc\n"
            "drops the line, Up/Down recall earlier ones. Ctrl-C quits.\n\n"
            "The port is locked while the monitor runs: another program opening\n"
            "it (imu-allan cmd, picocom) is told it is busy."
        ),
        epilog=(
            "exit status: 0 on Ctrl-C (or, with --once, after a report), 1 the port "
            "was lost, 2 usage error or the port cannot be opened (or is busy)"
        ),
    )
    p.add_argument("--port", required=True, metavar="PORT", help="serial port, e.g. /dev/ttyUSB0")
    p.add_argument(
        "--baud",
        type=_baud,
        default=115200,
        metavar="B",
        help="baud rate (default 115200, the firmware's default BAUD)",
    )
    p.add_argument(
        "--log",
        metavar="FILE",
        help=(
            "file to append everything received to, or a directory (ending in /) for a new "
            "imu-allan-YYYYmmdd-HHMMSS.log in it (default: in imu-allan-logs/, made if missing)"
        ),
    )
    p.add_argument("--once", action="store_true", help="exit after the first complete report (for scripts)")


def _command_synopsis(width: int = 76) -> str:
    """The device's commands with their arguments, in its own order and words
    (the firmware's tables, through _firmware_facts), wrapped to ``width``."""
    from .._firmware_facts import COMMAND_ARGS, MODES, ONOFF, RANGES_G, UNITS

    arg = {
        "none": "",
        "count": " [count]",
        "rate": " <hz>",
        "seconds": " <s>",
        "mode": f" <{'|'.join(MODES)}>",
        "range": f" <{'|'.join(RANGES_G)}>",
        "onoff": f" [{'|'.join(ONOFF)}]",
        "units": f" [{'|'.join(UNITS)}]",
    }
    words = [w + arg[kind] for w, kind in COMMAND_ARGS.items()]
    lines, line = [], "  "
    for w in words:
        if len(line) + len(w) + 2 > width:
            lines.append(line.rstrip())
            line = "  "
        line += w + ", "
    return "\n".join(lines + [line.rstrip(", ") + "."])


def _add_cmd(sub: Any) -> None:
    p = sub.add_parser(
        "cmd",
        help="send one command to the device and print its reply",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Send WORDS, joined by spaces, as one command line to the device and\n"
            "print its reply ('ok ...' or 'error:<code> <reason>'); whatever else\n"
            "the device sends meanwhile (reports, raw rows, binary frames) is\n"
            "ignored. Commands (docs/protocol.md):\n" + _command_synopsis() + "\n\n"
            "example: imu-allan cmd --port /dev/ttyUSB0 rate 250"
        ),
        epilog="a line answered 'error:5 input lost' (the device lost some of its bytes and ran "
        "nothing) is sent again, 3 times in all.\n"
        "exit status: 0 reply ok, 1 error reply or no reply in time, 2 usage error "
        "or the port cannot be opened",
    )
    p.add_argument("--port", required=True, metavar="PORT", help="serial port, e.g. /dev/ttyUSB0")
    p.add_argument("--baud", type=_baud, default=115200, metavar="B", help="baud rate (default 115200)")
    p.add_argument(
        "--timeout",
        type=_seconds,
        default=3.0,
        metavar="S",
        help="seconds to wait for the reply (default 3; a command waits while a report is being sent)",
    )
    p.add_argument("words", nargs="+", metavar="WORDS", help="the command and its argument")
