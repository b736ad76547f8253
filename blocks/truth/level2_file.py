"""The bytes of a NEXRAD Level-II (Archive II) file: its volume header, checked before the
file is read; whole-file gzip/bzip2 wrappers and the bzip2 records inside, decompressed within
bounds; and the messages of the records, one frame or message-31 length at a time.

:mod:`pasim_blocks.truth.level2` decodes the messages these yield.
"""

from __future__ import annotations

import bz2
import hashlib
import struct
import threading
import zlib
from collections import OrderedDict
from collections.abc import Iterator
from pathlib import Path
from typing import Any

# Level-II archives start with "AR2V00nn." (build 10+) or "ARCHIVE2." (older builds).
VOLUME_MAGIC = (b"AR2V", b"ARCHIVE2")
VOLUME_HEADER = struct.Struct(">9s3sII4s")  # tape, extension, date, time, ICAO
VOLUME_HEADER_BYTES = 24
# Each message is preceded by 12 bytes of channel terminal manager (CTM) data.
CTM_BYTES = 12
# Every message but 31 fills one fixed frame; so does each of the metadata messages
# (15, 13, 18, 3, 5, 2) that open a volume.
FRAME_BYTES = 2432
METADATA_FRAMES = 134
# size (halfwords, header included), channels, type, sequence, date, ms, segments, segment
MSG_HEADER = struct.Struct(">HBBHHIHH")

#: Level-II volumes are a few to a hundred megabytes; a file far larger is not one, and is
#: refused before it is read into memory.
MAX_VOLUME_BYTES = 1 << 30
#: No volume decompresses beyond this (a record of a real one is about a megabyte): a bound
#: on what a damaged or hostile file can make the reader allocate.
MAX_DECOMPRESSED_BYTES = 2 << 30
MAX_RECORD_BYTES = 64 << 20

#: Decompressed records kept per process, keyed by the digest of their compressed bytes: a
#: study's runs, and the test suite's, read the same volume again and again, and bzip2 is
#: most of a read's time (about 0.6 s of CPU per read of the bundled scene). The key is the
#: content, so a changed file can never be answered from the cache.
RECORD_CACHE_BYTES = 256 << 20
_record_cache: OrderedDict[bytes, bytes] = OrderedDict()
_record_cache_size = 0
_record_cache_lock = threading.Lock()


def open_volume(path: Path) -> bytes:
    """Return the file's bytes with any whole-file gzip/bzip2 wrapper removed, validated.

    The first bytes are checked before the file is read: a file that is neither a Level-II
    volume nor a gzip or bzip2 wrapper is refused without reading the rest, and so is one
    larger than any volume.
    """
    if not path.is_file():
        raise FileNotFoundError(f"NEXRAD Level-II file not found (no such file): {path}")
    with path.open("rb") as f:
        head = f.read(VOLUME_HEADER_BYTES)
        wrapped = head[:2] == b"\x1f\x8b" or head[:3] == b"BZh"
        if not wrapped and not head.startswith(VOLUME_MAGIC):
            raise ValueError(
                f"{path} is not a NEXRAD Level-II (Archive II) volume: expected a 24-byte volume "
                f"header starting with 'AR2V' or 'ARCHIVE2', found {head[:8]!r}"
            )
        size = path.stat().st_size
        if size > MAX_VOLUME_BYTES:
            raise ValueError(
                f"{path} is {size / 2**30:.1f} GiB: larger than any Level-II volume "
                f"({MAX_VOLUME_BYTES / 2**30:.0f} GiB at most); is it the right file?"
            )
        raw = head + f.read()
    try:
        # Archive copies are often wrapped whole in gzip (.gz) or bzip2 (.bz2).
        if raw[:2] == b"\x1f\x8b":
            raw = bounded(zlib.decompressobj(wbits=31), raw, path, MAX_DECOMPRESSED_BYTES)
        elif raw[:3] == b"BZh":
            raw = bounded(bz2.BZ2Decompressor(), raw, path, MAX_DECOMPRESSED_BYTES)
    except (OSError, EOFError, zlib.error) as err:
        raise ValueError(f"{path}: corrupt gzip/bzip2 wrapper ({err})") from err
    if not raw.startswith(VOLUME_MAGIC) or len(raw) < VOLUME_HEADER_BYTES:
        raise ValueError(
            f"{path} is not a NEXRAD Level-II (Archive II) volume: expected a 24-byte volume "
            f"header starting with 'AR2V' or 'ARCHIVE2', found {raw[:8]!r}"
        )
    return raw


def bounded(
    decompressor: Any, data: bytes | memoryview, path: Path, limit: int, whole: bool = True
) -> bytes:
    """Decompress ``data`` (one stream), refusing output beyond ``limit`` bytes.

    With ``whole`` the stream must end inside ``data`` (a whole-file wrapper cut short is
    an error); without, what a cut-short record holds is returned.
    """
    if isinstance(decompressor, bz2.BZ2Decompressor):
        out = decompressor.decompress(data, max_length=limit + 1)
    else:
        out = decompressor.decompress(data, limit + 1)
    if len(out) > limit:
        raise ValueError(
            f"{path}: decompresses to more than {limit / 2**20:.0f} MiB, more than any Level-II "
            "volume holds: refused (a damaged or hostile file)"
        )
    if whole and not decompressor.eof:
        raise EOFError("the compressed stream ends before its end marker (a truncated file)")
    return out


class Truncation:
    """Where a truncated file ends: set by :func:`records` and :func:`messages`."""

    def __init__(self) -> None:
        self.at_byte: int | None = None


def records(raw: bytes, path: Path, cut: Truncation | None = None) -> Iterator[bytes]:
    """The volume's messages as decompressed records, one at a time, in file order.

    A compressed volume is a sequence of records, each a 4-byte big-endian length (negative
    for the last one) followed by one bzip2 stream; a plain volume is one record. Records
    are decompressed only when asked for, so a reader that stops early saves the rest.
    A record that runs past the end of the file (a cut-off download) is noted in ``cut``.
    """
    first = VOLUME_HEADER_BYTES
    if raw[first + 4 : first + 7] != b"BZh":
        yield raw[first:]
        return
    view = memoryview(raw)
    pos = first
    while pos + 4 <= len(raw):
        size = abs(int.from_bytes(raw[pos : pos + 4], "big", signed=True))
        if size == 0:
            break
        if cut is not None and pos + 4 + size > len(raw):
            cut.at_byte = len(raw)
        try:
            # A decompressor object returns what it can of a record cut short by a
            # truncated download; the sweep being read then ends incomplete.
            yield decompressed_record(view[pos + 4 : pos + 4 + size], path)
        except OSError as err:
            raise ValueError(f"{path}: corrupt bzip2 record at byte {pos} ({err})") from err
        pos += 4 + size
    if cut is not None and 0 < len(raw) - pos < 4:
        cut.at_byte = len(raw)


def decompressed_record(data: memoryview, path: Path) -> bytes:
    """One bzip2 record decompressed (within :data:`MAX_RECORD_BYTES`), from the process's
    cache of records when the same compressed bytes were decompressed before."""
    global _record_cache_size
    key = hashlib.blake2b(data, digest_size=20).digest()
    with _record_cache_lock:
        hit = _record_cache.get(key)
        if hit is not None:
            _record_cache.move_to_end(key)
            return hit
    out = bounded(bz2.BZ2Decompressor(), data, path, MAX_RECORD_BYTES, whole=False)
    with _record_cache_lock:
        if key not in _record_cache and len(out) <= RECORD_CACHE_BYTES // 4:
            _record_cache[key] = out
            _record_cache_size += len(out)
            while _record_cache_size > RECORD_CACHE_BYTES:
                _, old = _record_cache.popitem(last=False)
                _record_cache_size -= len(old)
    return out


def load_volume_bytes(path: Path) -> bytes:
    """The whole volume as uncompressed Level-II bytes (volume header + plain records)."""
    raw = open_volume(path)
    volume = bytearray(raw[:VOLUME_HEADER_BYTES] + b"".join(records(raw, path)))
    # Readers tell compressed from plain volumes by bytes 24..27; in plain records those are
    # the first message's CTM bytes, which Archive II leaves unused, so zeroing them is safe.
    volume[VOLUME_HEADER_BYTES : VOLUME_HEADER_BYTES + CTM_BYTES] = bytes(CTM_BYTES)
    return bytes(volume)


def messages(
    records: Iterator[bytes], cut: Truncation | None = None
) -> Iterator[tuple[bytes, int, int]]:
    """``(record, offset of the message header, message type)`` of every whole message.

    A message cut short (the file ends inside it) is noted in ``cut``.
    """
    count = 0
    for record in records:
        pos, end = 0, len(record)
        while pos + CTM_BYTES + MSG_HEADER.size <= end:
            at = pos + CTM_BYTES
            size, _, msg_type = MSG_HEADER.unpack_from(record, at)[:3]
            length = FRAME_BYTES
            if count >= METADATA_FRAMES or msg_type == 31:
                # Message 31 has its own length; others fill at least a frame.
                variable = CTM_BYTES + 2 * size
                length = variable if msg_type == 31 else max(variable, FRAME_BYTES)
                if length <= CTM_BYTES + MSG_HEADER.size:
                    length = FRAME_BYTES  # a zero-size message 31 is padding
            if pos + length > end:
                if cut is not None and cut.at_byte is None:
                    cut.at_byte = -1  # somewhere in the last record
                break  # cut short: a truncated record
            count += 1
            if msg_type != 0:  # type 0 frames are padding
                yield record, at, msg_type
            pos += length
