"""Reading and writing thesis rows."""

from pathlib import Path

import numpy as np
import pytest
from conftest import thesis_like, write_rows

from imu_allan.errors import InputError
from imu_allan.sources.rows import format_rows, iter_blocks, read_rows


def test_reads_comments_blank_lines_crlf_and_spaces(tmp_path: Path) -> None:
    p = tmp_path / "r.txt"
    p.write_bytes(
        b"# thesis rows\n\n498\t494\t791\t520\t497\t498\t63  # first\r\n"
        b"   \n0 1023 7 8 9 10 11\n#end\n1\t2\t3\t4\t5\t6\t0007"
    )  # no final newline
    got = read_rows(p)
    assert got.dtype == np.uint16 and got.shape == (7, 3)
    assert got.T.tolist() == [[498, 494, 791, 520, 497, 498, 63], [0, 1023, 7, 8, 9, 10, 11], [1, 2, 3, 4, 5, 6, 7]]


@pytest.mark.parametrize("block", [7, 64, 1000, 1 << 20])
def test_block_boundaries_do_not_matter(tmp_path: Path, block: int) -> None:
    rows = thesis_like(3000, 2)
    p = write_rows(tmp_path / "r.txt", rows)
    got = np.concatenate(list(iter_blocks(p, block_bytes=block)), axis=1)
    assert np.array_equal(got.T, rows)


@pytest.mark.parametrize(
    "text, message",
    [
        (b"1 2 3 4 5 6 7\n1 2 3 4 5 6\n", "line 2: 6 columns, expected 7"),
        (b"#c\n1 2 3 4 5 6 7 8\n", "line 2: 8 columns, expected 7"),
        (b"1 2 3 4 5 6 7\n\n1 2 3 4.5 5 6 7\n", "line 3: unexpected '.'"),
        (b"1 2 3 4 5 6 -7\n", "line 1: unexpected '-'"),
        (b"1 2 3 4 5 6 7\n1 2 3 4 5 6 1024\n", "line 2: code 1024 out of range 0..1023"),
        (b"1 2 3 4 5 6 99999999999\n", "line 1: code out of range"),
        (b"1 2 3 4 5 6 7\x00\n", "line 1: unexpected byte 0x00"),
    ],
)
def test_malformed_rows_name_file_and_line(tmp_path: Path, text: bytes, message: str) -> None:
    p = tmp_path / "bad.txt"
    p.write_bytes(text)
    with pytest.raises(InputError) as exc:
        read_rows(p)
    assert str(exc.value).startswith(f"{p}: ") and message in str(exc.value)
    assert "\n" not in str(exc.value)


def test_error_line_numbers_across_blocks(tmp_path: Path) -> None:
    rows = thesis_like(5000, 3)
    p = write_rows(tmp_path / "r.txt", rows, comment="# a\n# b\n")
    lines = p.read_bytes().split(b"\n")
    lines[4001] = b"1 2 3"  # file line 4002
    p.write_bytes(b"\n".join(lines))
    with pytest.raises(InputError, match="line 4002: 3 columns"):
        for _ in iter_blocks(p, block_bytes=4096):
            pass


def test_a_line_too_long_for_a_row_is_named_after_the_rows_before_it(tmp_path: Path) -> None:
    from imu_allan.sources.rows import MAX_ROW_LINE

    rows = thesis_like(3000, 5)
    p = write_rows(tmp_path / "r.txt", rows, comment="# a\n")
    p.write_bytes(p.read_bytes() + b"7" * (2 * MAX_ROW_LINE) + b"\n")
    got = []
    with pytest.raises(InputError, match=f"line {3000 + 2}: longer than"):
        for b in iter_blocks(p, block_bytes=1 << 12):
            got.append(b)
    assert np.array_equal(np.concatenate(got, axis=1).T, rows)  # every row before it, in order


def test_protocol_lines_are_skipped(tmp_path: Path, run_cli) -> None:
    """A raw capture (rows, count lines, replies) replays through the readers."""
    rows = thesis_like(250, 4)
    text = b"$B,proto=1,fw=0.2.0*ABCD\r\n$ok mode=raw # not a comment*1234\r\n"
    for i, r in enumerate(rows):
        text += "\t".join(map(str, r)).encode() + b"\r\n"
        if (i + 1) % 100 == 0:
            text += b"$C,%d*0000\r\n" % (i + 1)
    p = tmp_path / "cap.txt"
    p.write_bytes(text + b"$error:2 bad argument*1234")  # no final newline
    assert np.array_equal(read_rows(p).T, rows)
    got = np.concatenate(list(iter_blocks(p, block_bytes=100)), axis=1)
    assert np.array_equal(got.T, rows)
    p.write_bytes(b"1 2 3 4 5 6 7\n1 2 $C,1\n")  # '$' inside a row is an error
    with pytest.raises(InputError, match="line 2: unexpected '\\$'"):
        read_rows(p)


def test_format_round_trip(tmp_path: Path) -> None:
    rows = np.random.default_rng(1).integers(0, 1024, (7, 5000)).astype(np.uint16)
    rows[:, :4] = [0, 9, 10, 1023]
    text = format_rows(rows)
    assert text.splitlines()[0] == b"0\t0\t0\t0\t0\t0\t0"
    assert text.splitlines()[3] == b"1023\t" * 6 + b"1023"
    p = tmp_path / "r.txt"
    p.write_bytes(text)
    assert np.array_equal(read_rows(p), rows)
    assert text == "".join("\t".join(map(str, r)) + "\n" for r in rows.T.tolist()).encode()


def test_a_gzip_file_reads_like_the_plain_one(tmp_path, run_cli) -> None:
    """The real recording ships as .tsv.gz: read decompressed, by its magic bytes."""
    import gzip
    import json

    plain = tmp_path / "imu.txt"
    rc, _, err = run_cli("gen", "-n", "5000", "--seed", "4", "-o", plain)
    assert rc == 0, err
    packed = tmp_path / "imu.data"  # no .gz in the name: the content tells
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    a = run_cli("reference", plain, "--fs", "100", "--json")
    b = run_cli("reference", packed, "--fs", "100", "--json")
    assert a[0] == b[0] == 0 and json.loads(a[1])["rows"] == json.loads(b[1])["rows"]
    cut = tmp_path / "cut.gz"
    cut.write_bytes(packed.read_bytes()[:-40])
    rc, out, err = run_cli("reference", cut, "--fs", "100")
    assert rc == 2 and err.count("\n") == 1 and f"cannot read '{cut}'" in err
