"""Level-II files that decode but hold impossible values are refused by name, not run.

Forged from the bundled KLBB volume with an independent walk of the format (ICD 2620010:
records of a 4-byte size and a bzip2 stream; messages of 12 CTM bytes, a 16-byte header
and, for message 31, a body whose azimuth float sits 12 bytes in and whose block pointers
follow its 32-byte header): the first radial of the file gets a NaN or a 1234.5 deg azimuth,
or its reflectivity 65,535 gates (range to 16,386 km), or loses its moment pointers (a
damaged first record, which used to turn the run single-polarisation on another cut). Each
run exits 2 naming the file and what is wrong. A gzip bomb is refused at the decompression
bound, and a file that is not Level-II is refused from its first bytes.
"""

from __future__ import annotations

import bz2
import gzip
import math
import struct
from pathlib import Path

import pytest

from ..conftest import GRAPHS, ROOT, pasim

BUNDLED = ROOT / "blocks" / "data" / "KLBB20160601_150025_V06"
RUN = ["run", str(GRAPHS / "generic_radar.yaml"), "--sector", "282:284"]
RUN += ["--set", "scan.pulses=8"]


def plain_volume() -> bytearray:
    """The bundled volume with its bzip2 records decompressed (a plain Archive II file)."""
    raw = BUNDLED.read_bytes()
    out, pos = bytearray(raw[:24]), 24
    while pos + 4 <= len(raw):
        size = abs(int.from_bytes(raw[pos : pos + 4], "big", signed=True))
        if size == 0:
            break
        out += bz2.decompress(raw[pos + 4 : pos + 4 + size])
        pos += 4 + size
    out[24:36] = bytes(12)  # plain records: the first CTM bytes are unused
    return out


def first_radial(volume: bytearray) -> int:
    """Offset of the first message 31's body (after its 16-byte message header)."""
    pos, count = 24, 0
    while pos < len(volume):
        at = pos + 12
        size, _, msg_type = struct.unpack_from(">HBB", volume, at)
        if msg_type == 31:
            return at + 16
        length = 2432 if count < 134 else max(12 + 2 * size, 2432)
        pos += length
        count += 1
    raise AssertionError("no message 31")


def block(volume: bytearray, body: int, name: bytes) -> int:
    count = struct.unpack_from(">H", volume, body + 30)[0]
    for ptr in struct.unpack_from(f">{count}I", volume, body + 32):
        if volume[body + ptr : body + ptr + 4] == b"D" + name:
            return body + ptr
    raise AssertionError(name)


def forged(tmp_path: Path, fault: str) -> Path:
    volume = plain_volume()
    body = first_radial(volume)
    if fault == "nan azimuth":
        struct.pack_into(">f", volume, body + 12, math.nan)
    elif fault == "azimuth 1234.5":
        struct.pack_into(">f", volume, body + 12, 1234.5)
    elif fault == "65535 gates":
        struct.pack_into(">H", volume, block(volume, body, b"REF") + 8, 65535)
    elif fault == "no moments in the first radial":
        struct.pack_into(">H", volume, body + 30, 3)  # volume, elevation, radial blocks only
    path = tmp_path / "forged_V06"
    path.write_bytes(bytes(volume))
    return path


def test_the_plain_volume_itself_runs(tmp_path, capsys):
    """The forging walk is right: the unforged plain volume runs as the bundled file does."""
    path = tmp_path / "plain_V06"
    path.write_bytes(bytes(plain_volume()))
    code, err = pasim(capsys, *RUN, "--truth", str(path), "--out", str(tmp_path / "s"))
    assert code == 0, err


@pytest.mark.parametrize(
    ("fault", "said"),
    [
        ("nan azimuth", "azimuth nan deg is not in [0, 360)"),
        ("azimuth 1234.5", "azimuth 1234.5 deg is not in [0, 360)"),
        ("65535 gates", "65535 gates (at most 4000)"),
        ("no moments in the first radial", "carries no moment where"),
    ],
)
def test_impossible_values_are_refused_naming_the_record(tmp_path, capsys, fault, said):
    path = forged(tmp_path, fault)
    out = tmp_path / "s"
    code, err = pasim(capsys, *RUN, "--truth", str(path), "--out", str(out))
    assert code == 2, err
    assert str(path) in err and said in err, err
    assert "Traceback" not in err
    assert not out.exists()


def test_a_gzip_bomb_is_refused_at_the_bound(tmp_path, capsys, monkeypatch):
    import pasim_blocks.truth.level2_file as level2_file

    monkeypatch.setattr(level2_file, "MAX_DECOMPRESSED_BYTES", 8 << 20)
    path = tmp_path / "bomb_V06.gz"
    with gzip.open(path, "wb", compresslevel=9) as f:
        f.write(b"AR2V0006." + bytes(15))
        for _ in range(64):
            f.write(bytes(1 << 20))  # 64 MiB of zeros: 64 kB on disk
    assert path.stat().st_size < 200_000
    code, err = pasim(capsys, *RUN, "--truth", str(path), "--out", str(tmp_path / "s"))
    assert code == 2 and "decompresses to more than 8 MiB" in err, err


def test_a_file_that_is_not_level_2_is_refused_from_its_header(tmp_path, capsys):
    """The Level-II reader refuses from the first bytes; the truth block then tries the
    other formats' readers, and names each when none opens it."""
    from pasim_blocks.truth.nexrad_io import read_truth_sweep

    path = tmp_path / "image.h5"
    path.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(100_000))
    with pytest.raises(ValueError, match=r"is not a NEXRAD Level-II.*b'\\x89HDF"):
        read_truth_sweep(path)
    code, err = pasim(capsys, *RUN, "--truth", str(path), "--out", str(tmp_path / "s"))
    assert code == 2 and "no radar-file reader opens it" in err and "ODIM_H5" in err, err
