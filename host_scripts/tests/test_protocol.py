"""Framing and CRC, against binascii.crc_hqx (an independent CRC-16/CCITT-FALSE)."""

import os

import numpy as np
from conftest import crc, line
from hypothesis import given, settings
from hypothesis import strategies as st

from imu_allan.device.framing import MAX_BODY, crc16, crc16_many, frame, split_frames


def test_crc_check_value() -> None:
    assert crc16(b"123456789") == 0x29B1
    assert crc(b"123456789") == 0x29B1
    assert crc16(b"") == 0xFFFF


@settings(max_examples=200, derandomize=True)
@given(st.binary(max_size=300))
def test_crc_matches_binascii(data: bytes) -> None:
    assert crc16(data) == crc(data)


def test_crc_many_matches_binascii() -> None:
    rng = np.random.default_rng(5)
    bodies = [os.urandom(int(k)) for k in rng.integers(0, 201, 300)] + [b""]
    assert crc16_many(bodies).tolist() == [crc(b) for b in bodies]


def test_frame_is_the_device_format() -> None:
    assert frame("E,3,90") == line("E,3,90")
    assert frame("ok") == b"$ok*%04X\r\n" % crc(b"ok")


def test_split_counts_every_kind_of_loss() -> None:
    good = [line("ok"), line("ok started"), line("B,proto=1,fw=0.1.0,mcu=atmega168,reset=por")]
    bad_crc = bytearray(line("E,1,6"))
    bad_crc[3] ^= 0x01  # one bit of the body
    data = (
        b"noise\r\n"
        + good[0]
        + bytes(bad_crc)
        + b"$E,1,6\r\n"  # no *CRC: malformed
        + b"$E,1,6*12G4\r\n"  # not hex: malformed
        + b"$L,1,ax,0,3"
        + good[1]  # restart at the next $
        + line("ok").replace(b"\r\n", b"\n")  # bare LF is fine
        + line("ok", lower=True)  # lower-case hex: never sent, malformed
        + b"xx"
        + good[2]
        + b"$L,1,ax,0,3,000"
    )  # end of input mid-line
    f = split_frames(data)
    assert f.bodies == ["ok", "ok started", "ok", "B,proto=1,fw=0.1.0,mcu=atmega168,reset=por"]
    assert f.errors == {"bad_crc": 1, "malformed": 3, "restarted": 1, "truncated": 1, "garbage_bytes": 7}


def test_body_limits() -> None:
    ok = "S,1," + "x" * (MAX_BODY - 4)  # the protocol's longest body
    assert split_frames(line(ok)).bodies == [ok]
    long = split_frames(line(ok + "x"))
    assert long.bodies == [] and long.errors["malformed"] == 1
    ctrl = split_frames(line("ok\x01"))
    assert ctrl.bodies == [] and ctrl.errors["malformed"] == 1
    crlf_only = split_frames(b"\r\n\r\n")
    assert crlf_only.bodies == [] and not any(crlf_only.errors.values())
