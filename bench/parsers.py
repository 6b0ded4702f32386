"""Text parsers side by side: which one reads the rows and CSV files users have.

    PYTHONPATH=host_scripts python bench/parsers.py [--rows 1.2e6] [--rounds 5] [--json out.json]

Two files of ``--rows`` lines x 7 tab-separated columns, written here from a
seeded generator: the thesis rows file (7 integer codes 0..1023, no header)
and a float TSV with a header (``t ax ay az gx gy gz``, values like a logger's
``%.9g``). Each is read to the end, block by block, into (channels, rows)
float64 or uint16 arrays by

* ``numpy``: the project's numpy readers (rows.parse_exact for the codes,
  numpy.loadtxt per block for the floats: the CSV reader before pandas),
* ``pyarrow``: pyarrow.csv.open_csv, streamed record batches,
* ``pandas``: pandas.read_csv(engine="c", chunksize=...), when pandas is installed,
* ``compiled``: the project's compiled readers (stats/ck_text.c, the path the
  command takes: rows.parse_block for the codes, table.parse_csv for the floats),
  when the extension is built.

Rounds alternate the order of the readers (A B C, then C B A ...); each reader's
time is reported as median, min and max over the rounds, with its ratio to
pyarrow's per round (median, min, max). Values are checked equal across readers.
"""

from __future__ import annotations

import argparse
import io
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Iterator

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "host_scripts"))

BLOCK_BYTES = 1 << 22


def write_files(tmp: Path, n: int) -> tuple[Path, Path]:
    from imu_allan.sources.rows import format_rows

    rng = np.random.default_rng(7)
    codes = rng.integers(0, 1024, size=(7, n), dtype=np.int64)
    rows = tmp / "codes.tsv"
    rows.write_bytes(format_rows(codes))
    floats = tmp / "floats.tsv"
    t = np.arange(n) / 1000.0
    v = rng.normal(0.0, 0.05, size=(n, 6))
    with open(floats, "w") as f:
        f.write("t\tax\tay\taz\tgx\tgy\tgz\n")
        np.savetxt(f, np.column_stack([t, v]), fmt="%.9g", delimiter="\t")
    return rows, floats


def numpy_rows(path: Path) -> list[np.ndarray]:
    from imu_allan.sources.rows import parse_exact

    return [parse_exact(body, "codes", 1, 7) for body in _bodies(path, skip=False)]


def _bodies(path: Path, skip: bool) -> Iterator[bytes]:
    """Whole lines, about BLOCK_BYTES at a time (after the header when ``skip``)."""
    tail = b""
    with open(path, "rb") as f:
        if skip:
            f.readline()
        while True:
            chunk = f.read(BLOCK_BYTES)
            data = tail + chunk
            cut = data.rfind(b"\n") + 1 if chunk else len(data)
            body, tail = data[:cut], data[cut:]
            if body.strip():
                yield body
            if not chunk:
                return


def compiled_rows(path: Path) -> list[np.ndarray]:
    from imu_allan.sources.rows import parse_block

    return [parse_block(body, "codes", 1, 7) for body in _bodies(path, skip=False)]


def compiled_floats(path: Path) -> list[np.ndarray]:
    from imu_allan.sources.table import parse_csv

    cols = list(range(1, 7))
    return [
        np.vstack([t[None, :], v]) for v, t in (parse_csv(b, "f", 1, "\t", cols, 0) for b in _bodies(path, skip=True))
    ]


def numpy_floats(path: Path) -> list[np.ndarray]:
    return [np.loadtxt(io.BytesIO(b), delimiter="\t", ndmin=2).T.copy() for b in _bodies(path, skip=True)]


def pyarrow_read(path: Path, header: bool) -> list[np.ndarray]:
    from pyarrow import csv

    names = None if header else [f"c{i}" for i in range(7)]
    reader = csv.open_csv(
        str(path),
        read_options=csv.ReadOptions(block_size=BLOCK_BYTES, column_names=names),
        parse_options=csv.ParseOptions(delimiter="\t"),
    )
    out = []
    for batch in reader:
        out.append(np.vstack([c.to_numpy() for c in batch.columns]).astype(np.float64))
    return out


def pandas_read(path: Path, header: bool) -> list[np.ndarray]:
    import pandas as pd

    out = []
    with pd.read_csv(path, sep="\t", header=0 if header else None, engine="c", chunksize=1 << 18) as r:
        for chunk in r:
            out.append(np.ascontiguousarray(chunk.to_numpy(dtype=np.float64).T))
    return out


def measure(readers: dict, rounds: int) -> dict:
    names = list(readers)
    times: dict[str, list[float]] = {k: [] for k in names}
    ref = None
    for r in range(rounds):
        for k in names if r % 2 == 0 else names[::-1]:
            t0 = time.perf_counter()
            blocks = readers[k]()
            times[k].append(time.perf_counter() - t0)
            got = np.concatenate(blocks, axis=1).astype(np.float64)
            if ref is None:
                ref = got
            elif not np.array_equal(got, ref):
                raise SystemExit(f"{k}: values differ from {names[0]}'s")
    out = {}
    base = times["pyarrow"]
    for k in names:
        ratio = [a / b for a, b in zip(times[k], base)]
        out[k] = {
            "s_median": round(float(np.median(times[k])), 3),
            "s_min": round(min(times[k]), 3),
            "s_max": round(max(times[k]), 3),
            "over_pyarrow": {
                "median": round(float(np.median(ratio)), 2),
                "min": round(min(ratio), 2),
                "max": round(max(ratio), 2),
            },
        }
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", type=float, default=1.2e6)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--json", help="write the figures here too")
    a = ap.parse_args()
    try:
        import pandas  # noqa: F401

        has_pandas = True
    except ImportError:
        has_pandas = False
    from imu_allan.stats import kernels

    with tempfile.TemporaryDirectory() as d:
        rows, floats = write_files(Path(d), int(a.rows))
        res = {"rows": int(a.rows), "columns": 7, "rounds": a.rounds}
        for label, path, own, header in (
            ("integer_codes", rows, numpy_rows, False),
            ("float_tsv", floats, numpy_floats, True),
        ):
            readers = {"pyarrow": lambda p=path, h=header: pyarrow_read(p, h), "numpy": lambda p=path, f=own: f(p)}
            if has_pandas:
                readers["pandas"] = lambda p=path, h=header: pandas_read(p, h)
            if kernels.COMPILED:
                readers["compiled"] = lambda p=path, f=(compiled_rows if own is numpy_rows else compiled_floats): f(p)
            res[label] = measure(readers, a.rounds)
            res[label]["bytes"] = path.stat().st_size
    print(json.dumps(res, indent=1))
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
