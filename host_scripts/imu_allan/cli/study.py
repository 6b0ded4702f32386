"""``imu-allan sweep`` and ``imu-allan thermal``: the thesis' open questions
(section 9: more sample rates, thermal models, the dependence of the terms
on sample rate and temperature). ``add_subcommands`` registers them on the
main parser and returns their handlers."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Callable, Optional

SWEEP_DIR = "imu-allan-sweep"
"""The sweep's directory when neither -o nor --dir names one."""


def default_sweep_dir(cwd: Optional[Path] = None) -> Path:
    """build/imu-allan-sweep of the imu-allan checkout ``cwd`` is in (its root
    has the Makefile, firmware/vocab.h and host_scripts/), where the build's
    other outputs go and git ignores them; ./imu-allan-sweep elsewhere."""
    here = (cwd or Path.cwd()).resolve()
    for d in (here, *here.parents):
        if (d / "Makefile").is_file() and (d / "firmware" / "vocab.h").is_file() and (d / "host_scripts").is_dir():
            return d / "build" / SWEEP_DIR
    return here / SWEEP_DIR


def _rates(text: str) -> list[float]:
    from ..channels import RATES_HZ

    try:
        out = [float(x) for x in text.replace(" ", "").split(",") if x]
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a list of rates in Hz: {text!r} (e.g. 50,100,200)") from None
    if not out or any(not (0 < r < float("inf")) for r in out):
        raise argparse.ArgumentTypeError(f"rates must be positive numbers of Hz: {text!r}")
    other = [r for r in out if r not in RATES_HZ]
    if other:  # the device (and the firmware in the simulator) takes only its own rates
        raise argparse.ArgumentTypeError(
            f"{other[0]:g} Hz is not a rate of the device ({', '.join(map(str, RATES_HZ))} Hz)"
        )
    if len(set(out)) < len(out):
        raise argparse.ArgumentTypeError(f"a rate given twice: {text!r}")
    return sorted(out)


def _terms(text: str) -> tuple[str, ...]:
    names = tuple(t.strip().upper() for t in text.split(",") if t.strip())
    bad = [t for t in names if t not in ("Q", "N", "B", "K", "R")]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"terms are among Q,N,B,K,R: {text!r}")
    return tuple(t for t in ("Q", "N", "B", "K", "R") if t in names)


def _temp_scale(text: str) -> tuple[float, float]:
    try:
        a, _, b = text.partition(",")
        scale, offset = float(a), float(b or 0.0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected C_PER_COUNT,OFFSET_C, e.g. 0.3223,0: {text!r}") from None
    if not TEMP_SCALE_MIN <= scale <= TEMP_SCALE_MAX or not abs(offset) <= TEMP_OFFSET_MAX:
        raise argparse.ArgumentTypeError(
            f"C_PER_COUNT must be in {TEMP_SCALE_MIN:g} .. {TEMP_SCALE_MAX:g} and OFFSET_C within "
            f"+-{TEMP_OFFSET_MAX:g}: {text!r}"
        )
    return scale, offset


TEMP_SCALE_MIN = 1e-6
TEMP_SCALE_MAX = 1e3
TEMP_OFFSET_MAX = 1e4
"""Bounds of --temp-scale: far beyond any sensor (a 10-bit code spans at most
a million degrees), and finite, so that temperatures stay numbers."""


def add_subcommands(sub: Any) -> dict[str, Callable[[argparse.Namespace], int]]:
    _add_sweep(sub)
    _add_thermal(sub)
    return {"sweep": cmd_sweep, "thermal": cmd_thermal}


def _add_sweep(sub: Any) -> None:
    from ..channels import RATES_HZ
    from .argtypes import _positive_int, _seconds

    p = sub.add_parser(
        "sweep",
        help="on-device Allan results at several sample rates; terms against Fs",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Drive the device through each rate of --rates: 'rate', 'reset', sample\n"
            "for --seconds, 'report'. Only the final on-device report of each rate is\n"
            "used (no raw stream). From each: the IEEE 952 terms N, B, K with 95 %\n"
            "intervals (as 'imu-allan analyze LOG'), the thesis' sigma_sensor (ADEV at\n"
            "tau0), N_tau0 (the thesis' read-off ADEV(tau0) sqrt(tau0)), sigma_AVRW\n"
            "(N sqrt(Fs)), sigma_BIAS (1.0755 B), sigma_ARRW (K / sqrt(Fs)) and FIT%.\n"
            "Then each quantity's dependence on Fs as a power law Fs^b, with the 95 %\n"
            "interval of b, and in words: independent of Fs, grows or falls.\n\n"
            "--sim runs the real firmware in the simulator (build/host/imu-sim, 'make\n"
            "sim'), its ADC fed by the continuous sensor model (docs/thesis-questions.md)\n"
            "sampled at the instants the device's ADC samples at each rate, so noise\n"
            "above Fs/2 aliases as on the bench. --port drives a real board.\n\n"
            "Resumable: each finished rate is saved in DIR/sweep.json (-o/--dir); the\n"
            "same command again continues with the rates still missing."
        ),
        epilog="exit status: 0 success, 2 usage or input error",
    )
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--port", metavar="PORT", help="serial port of the board")
    g.add_argument("--sim", action="store_true", help="the firmware in the simulator, fed by the sensor model")
    p.add_argument("--baud", type=_positive_int, default=115200, help="with --port (default 115200)")
    p.add_argument("--model", metavar="FILE", help="sensor model (JSON) for --sim (default: thesis-like)")
    p.add_argument(
        "--rates",
        type=_rates,
        required=True,
        metavar="LIST",
        help=f"rates in Hz, e.g. 100,250,1000 (the device offers {', '.join(map(str, RATES_HZ))})",
    )
    p.add_argument("--seconds", type=_seconds, required=True, metavar="S", help="seconds of samples per rate")
    p.add_argument(
        "-o",
        "--dir",
        dest="dir",
        metavar="DIR",
        help=f"state and device logs (default: build/{SWEEP_DIR} of the imu-allan checkout "
        f"the command runs in, else ./{SWEEP_DIR})",
    )
    p.add_argument("--restart", action="store_true", help="discard a saved sweep in DIR")
    p.add_argument(
        "--profile",
        choices=("counts", "thesis"),
        default="counts",
        help="units: counts (default) or thesis (m/s^2, deg/s)",
    )
    p.add_argument("--seed", type=_positive_int, default=1, metavar="S", help="--sim: random seed")
    p.add_argument(
        "--average",
        type=_positive_int,
        default=1,
        metavar="M",
        help="--sim: model a device that averages M ADC scans per sample (anti-alias)",
    )
    p.add_argument("--firmware", metavar="ELF", help="--sim: firmware ELF")
    p.add_argument("--keep-rows", action="store_true", help="--sim: keep each rate's rows file in DIR")
    p.add_argument(
        "--fit-from",
        type=_seconds,
        metavar="TAU",
        help="fit the terms only at tau >= TAU seconds (e.g. above the sensors' low-pass "
        "time constants; default: the whole curve, as 'analyze')",
    )
    p.add_argument(
        "--terms",
        type=_terms,
        metavar="LIST",
        help="terms allowed in the fit, e.g. N,B,K (the thesis' model; default Q,N,B,K,R)",
    )
    p.add_argument("--json", action="store_true", help="print JSON: {rates, dependence, ...}")
    p.add_argument("--plot", metavar="DIR", help="write terms-vs-fs.png to DIR")


def _add_thermal(sub: Any) -> None:
    from .argtypes import _fs, _positive_int

    p = sub.add_parser(
        "thermal",
        help="bias against temperature; noise terms before and after removing it",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Read a raw-rows capture (thesis rows with the temperature column, or a\n"
            "raw/both capture) and, per channel: fit the bias against temperature,\n"
            "linear and, where an F-test at 95 % supports it, quadratic, with 95 %\n"
            "intervals (on block means, so that the correlated noise does not make\n"
            "them too narrow); the Allan deviation and the IEEE 952 terms before and\n"
            "after removing the fitted thermal bias; and the thermal term as part of\n"
            "the thesis' noise model, with its FIT%.\n\n"
            "The temperature column is in ADC codes unless --temp-scale gives degC\n"
            "per count and the offset in degC (the thesis does not name its sensor;\n"
            "an LM35 on the 3.3 V 10-bit ADC would be 0.3223,0)."
        ),
        epilog="exit status: 0 success, 2 usage or input error",
    )
    p.add_argument("file", metavar="FILE", help="rows file or raw capture with the temperature column")
    p.add_argument("--fs", type=_fs, metavar="HZ", help="sample rate (required for a rows file)")
    p.add_argument(
        "--temp-scale",
        type=_temp_scale,
        metavar="C_PER_COUNT,OFFSET_C",
        help="temperature channel scale (default: codes)",
    )
    p.add_argument(
        "--profile",
        choices=("counts", "thesis"),
        default="counts",
        help="units: counts (default) or thesis (m/s^2, deg/s)",
    )
    p.add_argument(
        "--scale",
        action="append",
        default=[],
        metavar="CH=VALUE[UNIT]",
        help="your sensor's scale per channel, as in imu-allan analyze (e.g. gx=0.0175, gx=1rad/s, "
        "ax=0.0039g); channels without one keep the --profile's units",
    )
    p.add_argument(
        "--segments",
        type=_positive_int,
        default=3,
        metavar="K",
        help="N and B in K consecutive segments against their temperature (default 3; 1: off)",
    )
    p.add_argument(
        "--outliers",
        choices=("replace", "keep"),
        default="replace",
        help="spikes and bursts: replace (default; before the regression and the terms) "
        "or keep (counted only); see imu-allan analyze --help",
    )
    p.add_argument("--json", action="store_true", help="print JSON: {channels: {gx: {tempco, ...}}}")
    p.add_argument("--plot", metavar="DIR", help="write thermal.png to DIR")


def cmd_sweep(args: argparse.Namespace) -> int:
    from ..analysis import sweep, sweep_devices
    from ..errors import InputError

    if args.port and (args.model or args.average != 1 or args.keep_rows):
        raise InputError("--model, --average and --keep-rows go with --sim")
    model = None
    if args.sim:
        model = _load_model(args.model).doc
    cfg = sweep.SweepConfig(
        source="sim" if args.sim else f"port:{args.port}",
        rates=args.rates,
        seconds=args.seconds,
        profile=args.profile,
        model=model,
        seed=args.seed,
        average=args.average,
        fit_from=args.fit_from,
        terms=args.terms,
    )
    sw = sweep.open_sweep(cfg, args.dir or str(default_sweep_dir()), restart=args.restart)
    measure = (
        sweep_devices.sim_measure(sw, args.firmware, args.keep_rows)
        if args.sim
        else sweep_devices.port_measure(sw, args.port, args.baud)
    )
    sweep.run(sw, measure, sweep.say_stderr)
    return _emit("sweep", sweep.document(sw), sweep, args)


def cmd_thermal(args: argparse.Namespace) -> int:
    from ..analysis import thermal
    from ..profiles import parse_scales
    from ..render import thermal as thermal_text

    doc = thermal.study(
        args.file,
        fs=args.fs,
        temp_scale=args.temp_scale,
        profile=args.profile,
        segments=max(args.segments, 1),
        outliers_mode=args.outliers,
        scales=parse_scales(args.scale),
    )
    if args.plot and not doc["fitted"]:
        print("imu-allan thermal: no plot: nothing was fitted", file=sys.stderr)
        args.plot = None
    return _emit("thermal", doc, thermal_text, args)


def _emit(command: str, doc: dict[str, Any], module: Any, args: argparse.Namespace) -> int:
    """The plot (--plot DIR) and the document as text or JSON (--json)."""
    if args.plot:
        from ..render import plots

        path = getattr(plots, f"{command}_plot")(doc, args.plot)
        print(f"imu-allan {command}: wrote {path}", file=sys.stderr)
    sys.stdout.write(json.dumps(doc, indent=1) + "\n" if args.json else module.text(doc))
    return 0


def _load_model(path: Any) -> Any:
    """``sensor.load_model``, a file that is not a model's JSON (binary bytes, a
    section that is not an object) refused in one line like its other errors."""
    from ..errors import InputError
    from ..noise.sensor import load_model

    try:
        return load_model(path)
    except (UnicodeDecodeError, AttributeError, TypeError) as exc:
        raise InputError(f"'{path}': not a sensor model (a JSON object of objects: {type(exc).__name__})") from None


def write_model_rows(path: str, model: Any, fs: float, n: int, seed: int = 1) -> None:
    """A rows file (thesis format) of the sensor model's board sampled at fs."""
    from ..noise.sensor import Board, rows_header
    from ..sources.rows import write_rows

    write_rows(path, rows_header(fs, n, seed), Board(model, fs, n, seed=seed).blocks())


def gen_from_model(args: argparse.Namespace) -> int:
    """``imu-allan gen --model FILE``: rows of the continuous sensor model (sensor.py)."""
    from ..errors import InputError
    from ..noise.gen import PARAMS

    given = [f"--{p.replace('_', '-')}" for p in PARAMS if getattr(args, p, None) is not None]
    if args.kind != "noise" or args.json_params:
        given.append("--kind" if args.kind != "noise" else "--json-params")
    if given:
        raise InputError(f"--model sets every parameter (in its file): {', '.join(given)} not allowed with it")
    write_model_rows(args.output, _load_model(args.model), float(args.fs), args.n, seed=args.seed)
    return 0


def sim_from_model(args: argparse.Namespace) -> int:
    """``imu-allan sim --model FILE``: the firmware in imu-sim, its ADC fed by the sensor model
    sampled at the instants the device samples at --fs (default 100 Hz)."""
    import os
    import tempfile

    from ..device.simrun import run, sim_command
    from ..errors import InputError

    if args.adc and args.model:
        raise InputError("--adc and --model: give one")
    if not args.model:
        raise InputError("the ADC needs --adc FILE or --model MFILE")
    fs = float(args.fs or 100)
    fd, rows = tempfile.mkstemp(prefix="imu-allan-model-", suffix=".tsv")
    os.close(fd)
    try:
        write_model_rows(rows, _load_model(args.model), fs, int(round(args.seconds * fs)))
        return run(
            sim_command(rows, args.output, fs=f"{fs:g}", uart_in=args.uart_in, firmware=args.firmware, stats=args.stats)
        )
    finally:
        os.unlink(rows)
