"""The compiled text readers (stats/ck_text.c) against the readers they
speed up: the rows reader against rows.py's numpy reader of the format
(values, and the line named on a fault), the table reader against pandas'
C reader (the same float64 bits, the same dtype of the time column, the
same error naming file and line)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from imu_allan.errors import InputError
from imu_allan.sources import rows, table
from imu_allan.stats import kernels

pytestmark = pytest.mark.skipif(not kernels.COMPILED, reason="the compiled kernels are not built")


def _either(fn: Any, *args: Any) -> Any:
    try:
        return fn(*args)
    except InputError as exc:
        return str(exc)


def _rows_text(rng: np.random.Generator, n: int) -> bytes:
    """Rows of 7 codes with the format's liberties, and now and then a fault."""
    out = []
    for _ in range(n):
        codes = [str(int(v)) for v in rng.integers(0, 1024, 7)]
        seps = rng.choice(["\t", " ", "  ", " \t"], 6)
        line = codes[0] + "".join(s + c for s, c in zip(seps, codes[1:]))
        r = rng.random()
        if r < 0.05:
            line += " # a comment 12 34"
        elif r < 0.08:
            line = "$C,12,34*AB"
        elif r < 0.10:
            line = ""
        elif r < 0.12:
            line = "  " + line + " \r"
        elif r < 0.125:
            line = line.replace(codes[3], "1024", 1) if codes[3] != "0" else line + " 5"
        elif r < 0.13:
            line = line.replace(codes[2], "0000000001", 1)
        elif r < 0.135:
            line = line.rsplit(None, 1)[0]
        elif r < 0.14:
            line = line.replace(codes[5], codes[5] + "x", 1)
        elif r < 0.145:
            line = line + " $"
        out.append(line)
    return ("\n".join(out) + ("\n" if rng.random() < 0.8 else "")).encode()


@pytest.mark.parametrize("seed", range(40))
def test_rows_reader_matches_the_exact_one(seed: int) -> None:
    """Every block reads as rows.py's numpy reader reads it: the same codes, or
    the same one-line error naming the same line."""
    rng = np.random.default_rng(seed)
    text = _rows_text(rng, int(rng.integers(1, 400)))
    want = _either(rows.parse_exact, text, "f", 10, 7)
    got = _either(rows.parse_block, text, "f", 10, 7)
    if isinstance(want, str):
        assert got == want
    else:
        assert got.dtype == want.dtype == np.uint16 and np.array_equal(got, want)
        fast = rows._compiled(text, 7)
        assert fast is not None  # the compiled reader read it, not the fallback
        assert fast[1] == text.count(b"\n")  # and counted its lines (the next block's first line)


def test_rows_reader_takes_comments_and_protocol_lines_itself() -> None:
    text = b"# head\n1 2 3 4 5 6 7 # x\n$C,1*00\n\n8\t9\t10\t11\t12\t13\t1023\r\n"
    got = rows._compiled(text, 7)
    assert got is not None and got[0].T.tolist() == [[1, 2, 3, 4, 5, 6, 7], [8, 9, 10, 11, 12, 13, 1023]]
    assert got[1] == 5


def _number(rng: np.random.Generator) -> str:
    v = float(rng.standard_normal() * 10.0 ** rng.integers(-9, 10))
    return str(
        rng.choice(
            [
                repr(v),
                f"{v:.17g}",
                f"{v:.6f}",
                f"{v:.3e}",
                f"{v:.20E}",
                str(int(v)),
                f"{v:+.2f}",
                "-0",
                "0.",
                ".5",
                "-.25e-3",
                "007",
                "1" * 25,
            ]
        )
    )


def _table_text(rng: np.random.Generator, n: int, delim: str, int_time: bool) -> bytes:
    lines = []
    t0 = 1_403_636_579_758_555_392  # EuRoC's ns stamps: 19 digits, beyond a double's 53 bits
    for k in range(n):
        t = str(t0 + k * 5_000_000) if int_time else f"{k * 0.005:.3f}"
        f = [t] + [_number(rng) for _ in range(6)] + ["note"]
        line = delim.join(f) if delim != " " else " ".join(f)
        r = rng.random()
        if r < 0.05:
            line = " " + line.replace(delim, " " + delim if delim != " " else "  ") + "  "
        elif r < 0.08:
            line += " # remark"
        elif r < 0.10:
            line = "# comment"
        elif r < 0.12:
            line = ""
        elif r < 0.14:
            line += "\r"
        lines.append(line)
    return ("\n".join(lines) + "\n").encode()


def _pandas(monkeypatch: pytest.MonkeyPatch, *args: Any) -> Any:
    with monkeypatch.context() as m:
        m.setattr(table, "_compiled", lambda *a: None)
        return _either(table.parse_csv, *args)


@pytest.mark.parametrize("delim", [",", ";", "\t", " "])
@pytest.mark.parametrize("int_time", [True, False])
@pytest.mark.parametrize("seed", range(3))
def test_table_reader_gives_pandas_values_bit_for_bit(
    monkeypatch: pytest.MonkeyPatch, delim: str, int_time: bool, seed: int
) -> None:
    """Negative numbers, exponents, integers, leading and trailing blanks,
    CR LF, comments and blank lines: the same float64 bits as pandas, and the
    time column int64 when pandas makes it so."""
    rng = np.random.default_rng(seed)
    body = _table_text(rng, 300, delim, int_time)
    sep = None if delim == " " else delim
    cols, tcol = [1, 2, 3, 4, 5, 6], 0
    assert table._compiled(body, sep, cols, tcol) is not None  # the compiled reader took it
    got = table.parse_csv(body, "f", 1, sep, cols, tcol)
    want = _pandas(monkeypatch, body, "f", 1, sep, cols, tcol)
    assert got[0].view(np.int64).tolist() == want[0].view(np.int64).tolist()  # -0.0 included
    assert got[1].dtype == want[1].dtype == (np.int64 if int_time else np.float64)
    assert np.array_equal(got[1], want[1])


@pytest.mark.parametrize(
    "body",
    [
        b"1,2,3\n4,,6\n",
        b"1,2,3\n4,5\n",
        b"1,2,3\n4,5,6,7\n",
        b"1,2,3\n4,abc,6\n",
        b'1,2,3\n4,"5",6\n',
        b"1,2,3\n4,5,nan\n",
        b"1,2,3\n4,5,1e999\n",
        b"1,2,3\n4,0x10,6\n",
        b"1,2,3\r4,5,6\n",
    ],
)
def test_table_reader_leaves_every_doubt_to_pandas(monkeypatch: pytest.MonkeyPatch, body: bytes) -> None:
    """An empty field, a ragged row, a word, quotes, nan/inf, hex, a lone CR:
    the compiled reader declines, and the answer (values or the error naming
    the line) is pandas'."""
    assert table._compiled(body, ",", [1, 2], 0) is None
    got = _either(table.parse_csv, body, "f", 7, ",", [1, 2], 0)
    want = _pandas(monkeypatch, body, "f", 7, ",", [1, 2], 0)
    if isinstance(want, str):
        assert got == want and got.startswith("'f': line ")
    else:
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])


def test_a_csv_file_reads_alike_both_ways(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A whole file through load(): the compiled reader and pandas give the same blocks."""
    from imu_allan.sources.detect import load

    rng = np.random.default_rng(5)
    body = _table_text(rng, 3000, ",", True)
    p = tmp_path / "imu.csv"
    p.write_bytes(b"t_ns,ax,ay,az,gx,gy,gz,label\n" + body)
    fast = np.concatenate(list(load(str(p)).samples.open_blocks()), axis=1)
    monkeypatch.setattr(table, "_compiled", lambda *a: None)
    slow = np.concatenate(list(load(str(p)).samples.open_blocks()), axis=1)
    assert fast.view(np.int64).tolist() == slow.view(np.int64).tolist()


def _csv_with_fault(rng: np.random.Generator, n: int, fault: str, at: int) -> tuple[list[str], int]:
    """Kalibr-style lines (header first) with blank lines and comments here and
    there, and one faulty row put at list index ``at``: the lines and the
    faulty row's line number, counted on the list itself (1 = the header)."""
    lines = ["timestamp,omega_x,omega_y,omega_z,alpha_x,alpha_y,alpha_z"]
    for k in range(n):
        if k % 97 == 5:
            lines.append("")
        elif k % 89 == 7:
            lines.append("# a comment, with, separators")
        lines.append(f"{1_700_000_000_000_000_000 + k * 5_000_000}," + ",".join(_number(rng) for _ in range(6)))
    good = lines[at].split(",")
    lines[at] = {
        "short": ",".join(good[:3]),
        "long": ",".join(good + ["0.5"]),
        "word": ",".join(good[:2] + ["abc"] + good[3:]),
        "empty": ",".join(good[:4] + [""] + good[5:]),
        "nan": ",".join(good[:5] + ["nan"] + good[6:]),
        "garbage": "\x01\x02garbage",
    }[fault]
    return lines, at + 1


@pytest.mark.parametrize("fault", ["short", "long", "word", "empty", "nan", "garbage"])
@pytest.mark.parametrize("block", [1 << 12, 1 << 22])
def test_a_faulty_row_is_named_by_its_own_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fault: str, block: int
) -> None:
    """Wherever it falls (the first block or a later one, after blank lines and
    comments), a row with missing, extra, empty, non-numeric or non-finite
    fields stops the reading with one line naming the file and that row's line:
    an extra field is not dropped unseen."""
    from imu_allan.sources.detect import load

    monkeypatch.setattr(table, "BLOCK_BYTES", block)
    rng = np.random.default_rng(11)
    lines, lineno = _csv_with_fault(rng, 3000, fault, 2500)
    p = tmp_path / "imu.csv"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError) as exc:
        list(load(str(p)).samples.open_blocks())
    msg = str(exc.value)
    assert msg.startswith(f"'{p}': line {lineno}: ") and "\n" not in msg


def test_a_trailing_separator_on_every_row_loses_nothing(tmp_path: Path) -> None:
    """``1,2,3,`` under a header of three names: an empty last field, read as the
    same values as without it."""
    from imu_allan.sources.detect import load

    x = np.random.default_rng(3).normal(size=(400, 3))
    p, q = tmp_path / "a.csv", tmp_path / "b.csv"
    p.write_text(
        "t,gx [rad/s],gy [rad/s]\n"
        + "".join(f"{k / 100!r},{float(v[1])!r},{float(v[2])!r},\n" for k, v in enumerate(x))
    )
    q.write_text(
        "t,gx [rad/s],gy [rad/s]\n" + "".join(f"{k / 100!r},{float(v[1])!r},{float(v[2])!r}\n" for k, v in enumerate(x))
    )
    a = np.concatenate(list(load(str(p)).samples.open_blocks()), axis=1)
    assert np.array_equal(a, x[:, 1:].T)
    assert np.array_equal(a, np.concatenate(list(load(str(q)).samples.open_blocks()), axis=1))
