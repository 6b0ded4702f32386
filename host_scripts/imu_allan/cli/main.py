"""The ``imu-allan`` command line: each command reads with the device layer,
computes with the stats layer (or analysis/) and prints with render/.
No domain logic lives here; the parser and every --help text are in args.py."""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import sys
from typing import Any, BinaryIO, Iterator, Optional

from ..channels import CHANNELS
from ..errors import InputError
from .args import EXIT_LOST, build_parser
from .study import add_subcommands


def cmd_decode(args: argparse.Namespace) -> int:
    from ..device.files import read_blocks
    from ..device.records import decode_blocks
    from ..render import formats
    from ..render import text as render

    res = decode_blocks(read_blocks(args.log))
    _warn("decode", res.warnings)
    if not res.reports:
        lost = ", ".join(f"{k} {v}" for k, v in res.errors.items() if v) or "the log is empty"
        print(
            f"imu-allan decode: no complete report in '{args.log}' (not used: {lost})" + _refused(res.refused),
            file=sys.stderr,
        )
        return 1
    docs = [render.report_doc(r) for r in (res.reports if args.all else res.reports[-1:])]
    if args.json:
        if args.all:
            sys.stdout.write(formats.to_json({"reports": docs, "errors": res.errors, "warnings": res.warnings}))
        else:
            sys.stdout.write(
                formats.to_json(
                    {**docs[0], "errors": res.errors, "complete_reports": len(res.reports), "warnings": res.warnings}
                )
            )
    elif args.csv:
        sys.stdout.write(formats.to_csv(docs, with_seq=args.all))
    else:
        sys.stdout.write(render.decode_text(docs, len(res.reports), args.log, args.all, res.errors))
    return 0


WARNINGS_SHOWN = 10
"""Warnings printed one per line; the rest are counted in one more line."""


def _warn(command: str, warnings: list[str]) -> None:
    """What the reader must know next to the reports, on stderr, a line each."""
    for w in warnings[:WARNINGS_SHOWN]:
        print(f"imu-allan {command}: warning: {w}", file=sys.stderr)
    if len(warnings) > WARNINGS_SHOWN:
        print(f"imu-allan {command}: warning: ... and {len(warnings) - WARNINGS_SHOWN} more", file=sys.stderr)


def _refused(reasons: list[str]) -> str:
    return f"; refused: {reasons[-1]}" if reasons else ""


def cmd_reference(args: argparse.Namespace) -> int:
    from ..render import formats
    from ..render import text as render
    from ..sources.rows import iter_blocks
    from ..stats.reference import OctaveCascade

    cascade = OctaveCascade(args.levels, len(CHANNELS))
    for block in iter_blocks(args.file):
        cascade.push(block[: len(CHANNELS)])
    if cascade.n == 0:
        raise InputError(f"'{args.file}' holds no rows (a rows file has 7 integer codes per line)")
    doc = render.reference_doc(cascade, args.file, args.fs)
    if args.json:
        sys.stdout.write(formats.to_json({**doc, "errors": {}}))
    elif args.csv:
        sys.stdout.write(formats.to_csv([doc]))
    else:
        sys.stdout.write(render.reference_text(doc))
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    from ..analysis.check import check_report, summary
    from ..device.files import read_blocks
    from ..device.records import decode_blocks

    if args.log == "-" and args.file == "-":
        raise InputError("LOG and FILE cannot both be stdin")
    res = decode_blocks(read_blocks(args.log))
    _warn("check", res.warnings)
    if not res.reports:
        print(f"imu-allan check: no complete report in '{args.log}'" + _refused(res.refused), file=sys.stderr)
        return 1
    rep = res.reports[-1]
    result = check_report(rep, args.file, args.fs)
    sys.stdout.write(summary(result, rep, args.log, args.file))
    return 0 if result.ok else 1


def cmd_gen(args: argparse.Namespace) -> int:
    if args.model:
        from .study import gen_from_model

        return gen_from_model(args)
    from ..noise.gen import PARAMS, generate, make_params
    from ..sources.rows import format_rows

    params = make_params(
        n=args.n,
        fs_hz=args.fs,
        seed=args.seed,
        kind=args.kind,
        profile=args.profile,
        **{p: getattr(args, p) for p in PARAMS},
    )
    head = f"# {params.command()}\n# columns: {' '.join(params.channels)} (10-bit ADC codes), {params.fs_hz:g} Hz\n"
    with _output(args.output) as f:
        f.write(head.encode())
        for block in generate(params):
            f.write(format_rows(block))
    if args.json_params:
        _write_text(args.json_params, params.to_json())
    return 0


def cmd_sim(args: argparse.Namespace) -> int:
    if args.model or not args.adc:
        from .study import sim_from_model

        return sim_from_model(args)
    from ..device.simrun import run, sim_command

    return run(
        sim_command(args.adc, args.output, fs=args.fs, uart_in=args.uart_in, firmware=args.firmware, stats=args.stats),
        adc=args.adc,
        fs=args.fs,
    )


def cmd_rows(args: argparse.Namespace) -> int:
    from ..device.capture import decode_chunks
    from ..device.files import input_name, read_blocks
    from ..device.stream import LOSS_KEYS, StreamDecoder
    from ..sources.rows import format_rows

    name = input_name(args.log)
    dec = StreamDecoder(verified_only=True)
    written = frames = 0
    blocks = read_blocks(args.log)
    with _output(args.output) as dst:
        dst.write(f"# imu-allan rows {name}\n# columns: ax ay az gx gy gz temp (10-bit ADC codes)\n".encode())
        for chunk in decode_chunks(blocks, dec):
            if chunk.samples.shape[1]:
                dst.write(format_rows(chunk.samples))
                written += chunk.samples.shape[1]
                frames += int(chunk.from_frame.sum())
    c = dec.counts
    if written == 0:
        print(
            f"imu-allan rows: no raw rows or binary frames in '{name}' "
            f"(bad rows {c['bad_rows']}, bad frames {c['bad_frames']})",
            file=sys.stderr,
        )
        return 1
    if c["blocks_verified"] or c["blocks_bad"]:
        checked = (
            f"; {c['blocks_verified']} blocks verified by their count line's CRC, "
            f"{c['rows_dropped']} rows dropped ({c['blocks_bad']} bad blocks holding "
            f"{c['rows_in_bad_blocks']} rows: a row changed, lost or added; "
            f"{c['rows_unverified']} rows written unverified: no block CRC covers them)"
        )
    else:
        checked = (
            "; unverified: the capture's count lines carry no block CRC (older firmware)"
            if c["count_lines"]
            else "; unverified: no count lines"
        )
    print(
        f"imu-allan rows: {written} rows written to {args.output} ({written - frames} from raw "
        f"rows, {frames} from binary frames){checked}; bad rows {c['bad_rows']}, rows lost "
        f"{c['rows_lost']} (count lines), frames lost {c['frames_lost']}, "
        f"bad frames {c['bad_frames']}, device drops {c['device_drops']} (sample sets the "
        "device itself lost, per its count lines)",
        file=sys.stderr,
    )
    return EXIT_LOST if c["rows_dropped"] or any(c[k] for k in LOSS_KEYS) else 0


def cmd_monitor(args: argparse.Namespace) -> int:
    from .monitor import run_monitor

    return run_monitor(args.port, args.baud, args.log, args.once)


def cmd_cmd(args: argparse.Namespace) -> int:
    from ..device.link import PortError, command_line, open_port, send_command

    line = command_line(args.words)
    ser = open_port(args.port, args.baud)
    try:
        for _ in range(CMD_TRIES):  # error:5: the device lost bytes of the line, it ran nothing
            reply = send_command(ser, line, args.timeout)
            if reply is None or not reply.startswith("error:5"):
                break
    except PortError as exc:
        print(f"imu-allan cmd: {args.port}: connection lost ({exc})", file=sys.stderr)
        return 1
    finally:
        ser.close()
    if reply is None:
        print(f"imu-allan cmd: no reply from {args.port} within {args.timeout:g} s", file=sys.stderr)
        return 1
    print(reply)
    return 0 if reply.startswith("ok") else 1


CMD_TRIES = 3
"""Times ``cmd`` sends a line the device answered ``error:5 input lost``."""


def cmd_analyze(args: argparse.Namespace) -> int:
    from ..profiles import build_profile, parse_scales, resolve_range, scales_for_input
    from ..sources.detect import check_options, load, load_device_report

    scales = parse_scales(args.scale)
    src = load(args.file, topic=args.topic)
    check_options(src, args.fs, scales)
    from ..analysis.warmup import skipped, warmup_section

    src, skip_note, _ = skipped(src, args.file, args.skip or 0.0, args.fs)
    if skip_note:
        src.notes.append(skip_note)
    device = load_device_report(args.device) if args.device else None
    report = device or src.report
    range_g = resolve_range(args.range, report.header.range_g if report is not None else None)
    samples = src.samples
    if samples is not None and args.profile is None and (samples.units or not samples.integer):
        scales = scales_for_input(src.name, samples.channels, samples.integer, samples.units, scales)
    profile = build_profile(args.profile, scales, range_g, samples.channels if samples is not None else None)
    from ..analysis.store import read_ahead

    read_ahead(samples, args.channels, args.memory * 2**20)  # while the statistics' modules load
    from ..analysis.pipeline import Options, analyze

    opts = Options(
        fs=args.fs,
        taus=args.taus,
        channels=args.channels,
        model=not args.no_model,
        seed=args.seed,
        memory_budget=args.memory * 2**20,
        outliers=args.outliers,
        horizon=args.horizon,
        keep_store=not args.no_warmup,
    )
    result = analyze(src, profile, opts, device=device)
    doc = result.doc
    from ..analysis import advice  # warm-up and stationarity, and how long to record (docs/dynamic.md)

    if not args.no_warmup:
        quick = Options(**{**vars(opts), "model": False, "extra_curves": False, "keep_store": False})
        try:
            warmup_section(
                doc, src, args.file, args.fs, lambda other: analyze(other, profile, quick, device).doc, result.store
            )
        finally:
            result.close()
    advice.add_to_analysis(doc, fits=result.fits)
    from ..analysis.device_terms import add_device_terms

    add_device_terms(doc, report)
    _analysis_out(args, doc, getattr(src.samples, "topic", None))
    return 0


def _analysis_out(args: argparse.Namespace, doc: dict, bag_topic: Optional[str]) -> None:
    """analyze's files (curves, estimator YAMLs, figures), then its stdout: JSON, CSV,
    the answer table alone (--brief) or the whole text (through the pager at a terminal)."""
    from ..analysis import advice
    from ..analysis.overbound import analysis_text as overbound_text
    from ..analysis.warmup import warmup_text
    from ..render import formats
    from ..render import text as render

    written = []
    if args.curves:
        written.append(_write_text(args.curves, formats.curves_csv(doc)))
    topic = getattr(args, "topic", None) or bag_topic or "/imu0"
    if args.kalibr:
        written.append(_write_text(args.kalibr, formats.kalibr_yaml(doc, topic, args.noise)))
    if args.openvins:
        written.append(_write_text(args.openvins, formats.openvins_yaml(doc, topic, args.noise)))
    if args.vins:
        written.append(_write_text(args.vins, formats.vins_yaml(doc, args.noise)))
    if args.imu_utils:
        written.append(_write_text(args.imu_utils, formats.imu_utils_yaml(doc)))
    if args.plot:
        from ..render.plots import write_plots

        written += write_plots(doc, args.plot)
    if args.json:
        sys.stdout.write(formats.to_json(doc))
    elif args.csv:
        sys.stdout.write(formats.terms_csv(doc))
    elif args.brief:
        from ..render.answer import answer_table

        sys.stdout.write(answer_table(doc, brief=True))
    else:
        from .pager import page

        page(render.text(doc) + warmup_text(doc) + advice.analysis_text(doc) + overbound_text(doc))
    for path in written:
        print(f"imu-allan analyze: wrote {path}", file=sys.stderr)


# ---- output files ----------------------------------------------------------------------


@contextlib.contextmanager
def _output(path: str) -> Iterator[BinaryIO]:
    """A binary output file (``-``: stdout); any error writing or closing it
    is one line naming it (exit 2)."""
    where = "stdout" if path == "-" else f"'{path}'"
    try:
        f = sys.stdout.buffer if path == "-" else open(path, "wb")
    except OSError as exc:
        raise InputError(f"cannot write {where}: {exc.strerror or exc}") from None
    try:
        with contextlib.ExitStack() as stack:
            if f is not sys.stdout.buffer:
                stack.enter_context(f)
            yield f
            f.flush()
    except OSError as exc:
        raise InputError(f"cannot write {where}: {exc.strerror or exc}") from None


def _write_text(path: str, text: str) -> str:
    try:
        with open(path, "w") as f:
            f.write(text)
    except OSError as exc:
        raise InputError(f"cannot write '{path}': {exc.strerror or exc}") from None
    return path


COMMANDS = {
    "analyze": cmd_analyze,
    "decode": cmd_decode,
    "reference": cmd_reference,
    "check": cmd_check,
    "gen": cmd_gen,
    "sim": cmd_sim,
    "rows": cmd_rows,
    "monitor": cmd_monitor,
    "cmd": cmd_cmd,
}


class _ClosedStream:
    """Stands for a stdout the caller closed (``>&-``): writing to it fails
    like writing to a closed descriptor, so the error path is the same."""

    def __getattr__(self, name: str) -> object:
        if name in ("write", "flush", "writelines"):
            raise OSError(errno.EBADF, "stdout is closed")
        if name == "buffer":
            return self
        raise AttributeError(name)


def main(argv: Optional[list[str]] = None) -> int:
    handlers = dict(COMMANDS)

    def more(sub: Any) -> None:
        handlers.update(add_subcommands(sub))  # sweep, thermal
        from .dynamic import add_subcommands as add_dynamic

        handlers.update(add_dynamic(sub))  # dynamic

    parser = build_parser(more)
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    if sys.stdout is None:
        sys.stdout = _ClosedStream()  # type: ignore[assignment]
    if not getattr(args, "quiet", False):
        _draw_progress()
    try:
        rc = handlers[args.command](args)
        sys.stdout.flush()
        return rc
    except InputError as exc:
        if isinstance(sys.stdout, _ClosedStream):
            sys.stdout = None  # type: ignore[assignment]  # nothing left for the final flush
        print(f"imu-allan {args.command}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except OSError as exc:  # stdout full, closed, or its reader gone: one line, exit 2
        if not isinstance(exc, BrokenPipeError) and exc.errno not in (
            errno.EPIPE,
            errno.EBADF,
            errno.ENOSPC,
            errno.EIO,
        ):
            raise
        _quiet_stdout()
        print(f"imu-allan {args.command}: cannot write stdout: {exc.strerror or exc}", file=sys.stderr)
        return 2


def _draw_progress() -> None:
    """Long work shows its progress line on stderr (a terminal only)."""
    from .. import progress
    from ..render.progress import Progress

    progress.use(Progress)


def _quiet_stdout() -> None:
    """Point a failed stdout at /dev/null so that the interpreter's own final
    flush does not print a second error."""
    if isinstance(sys.stdout, _ClosedStream):
        sys.stdout = None  # type: ignore[assignment]
        return
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, AttributeError, ValueError):
        pass


if __name__ == "__main__":
    sys.exit(main())
