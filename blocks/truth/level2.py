"""NEXRAD Level-II (Archive II) decoding: the volume's records, messages 31 and 1, the VCP,
and the cuts of one elevation, down to each moment's codes and gate geometry.

:mod:`pasim_blocks.truth.nexrad_io` says why the messages are decoded here rather than by
xradar (cost, legacy files, masking); :mod:`pasim_blocks.truth.gridding` puts the decoded
moments on one grid.
"""

from __future__ import annotations

import math
import struct
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pasim_graph.fm301 import MOMENT_FIELDS
from pasim_graph.fm301 import POLARIMETRIC_FIELDS as SIGNAL_POLARIMETRIC_FIELDS

from .level2_file import (
    MSG_HEADER,
    VOLUME_HEADER,
    Truncation,
    messages,
    open_volume,
    records,
)

#: Every moment a truth sweep can carry, in xradar (ODIM-like) names.
FIELD_NAMES: tuple[str, ...] = MOMENT_FIELDS
#: Moments whose presence makes a sweep dual-polarisation.
POLARIMETRIC_FIELDS: tuple[str, ...] = SIGNAL_POLARIMETRIC_FIELDS
#: Moments taken from the surveillance (long PRT) cut of a split elevation.
SURVEILLANCE_FIELDS: tuple[str, ...] = ("DBZH", "ZDR", "RHOHV", "PHIDP")
#: Moments taken from the Doppler (short PRT) cut of a split elevation.
DOPPLER_FIELDS: tuple[str, ...] = ("VRADH", "WRADH")

# Level-II data block names as they appear in message 31 (message 1 has fixed slots).
_MOMENT_NAMES: dict[str, str] = {
    "REF": "DBZH",
    "ZDR": "ZDR",
    "RHO": "RHOHV",
    "PHI": "PHIDP",
    "VEL": "VRADH",
    "SW ": "WRADH",
}

# Codes 0 (below threshold) and 1 (range folded) are reserved in every Level-II moment.
_FIRST_DATA_CODE = 2
# 16-bit moments carry their code in the low bits (ICD 2620010, Table XVII-I).
_CODE_MASK_16 = {"PHIDP": 0x3FF, "ZDR": 0x7FF}

# Requests farther than this from every cut are almost certainly a wrong file or a typo.
_MAX_ELEVATION_MISMATCH_DEG = 1.0
# Split cuts repeat the VCP angle exactly; distinct VCP elevations are >= 0.4 deg apart.
_SAME_ELEVATION_DEG = 0.1


# ------------------------------------------------------------------ Level-II layout
# id, collect ms, collect date, azimuth number, azimuth (deg), compression, spare, radial
# length, azimuth resolution, radial status, elevation number, cut sector, elevation (deg),
# blanking, azimuth mode, block count; then up to 10 block pointers.
_MSG31 = struct.Struct(">4sIHHfBBHBBBBfBbH")
_MAX_BLOCKS = 10
# collect ms, collect date, unambiguous range, azimuth (BAMS), azimuth number, radial status,
# elevation (BAMS), elevation number, first gate (signed, m) and gate step (m) of the
# surveillance and Doppler data, surveillance and Doppler gate counts, cut sector,
# calibration, pointers to reflectivity, velocity and width, velocity resolution, VCP,
# spare, Nyquist velocity (0.01 m/s).
_MSG1 = struct.Struct(">IHhHHHHHhhHHHHHfHHHHH14xh")
_MSG1_ANGLE_DEG = 180.0 / 32768.0
# block id ("D" + name), reserved, gates, first gate (m), gate step (m), threshold, SNR
# threshold, control flags, word size (bits), scale, offset; the codes follow.
_GENERIC_BLOCK = struct.Struct(">4sIHhhhhBBff")
# block id, size, version (2 bytes), latitude, longitude, site height, feedhorn height
_VOLUME_BLOCK = struct.Struct(">4sHBBffhH")
# block id, size, unambiguous range, noise H, noise V, Nyquist velocity (0.01 m/s)
_RADIAL_BLOCK = struct.Struct(">4sHhffh")
# message 5: size, pattern type, pattern number, number of cuts, clutter group,
# velocity resolution, pulse width, spares; then one 46-byte entry per cut, whose first
# halfword is the elevation angle in units of 360/65536 deg.
_MSG5 = struct.Struct(">HHHHHBB10s")
_MSG5_CUT_BYTES = 46
_MSG5_ANGLE_DEG = 360.0 / 65536.0
_MAX_VCP_CUTS = 25
# Radial status: start of elevation / volume / last elevation; end of elevation / volume.
_CUT_START = (0, 3, 5)
_CUT_END = (2, 4)


class DamagedRecord(ValueError):
    """A Level-II message decodes but holds values no radar records."""


@dataclass(frozen=True)
class _Radial:
    """Where one radial message sits in its decompressed record, and its header."""

    record: bytes  # the decompressed record (or plain volume) holding the message
    at: int  # offset of the 16-byte message header in ``record``
    legacy: bool  # message 1 rather than message 31
    status: int
    elevation_number: int
    azimuth_deg: float
    elevation_deg: float
    time_ms: int  # milliseconds since 1970-01-01


@dataclass(frozen=True)
class _Block:
    """One moment's data block in one radial."""

    data_at: int  # offset of the first code in the record
    ngates: int
    first_gate_m: float
    gate_step_m: float
    word_size: int  # bits
    scale: float
    offset: float


@dataclass(frozen=True)
class Moment:
    """Undecoded codes of one moment for some radials of a cut, with their gate geometry."""

    codes: np.ndarray  # (radial, gate) unsigned integer codes; 0 where a radial lacks data
    first_gate_m: float  # range to the centre of the first gate
    gate_step_m: float
    scale_factor: float  # value = code * scale_factor + add_offset
    add_offset: float

    def decode(self) -> np.ndarray:
        """float32 physical values, NaN for codes 0 and 1."""
        values = self.codes.astype(np.float64) * self.scale_factor + self.add_offset
        return np.where(self.codes >= _FIRST_DATA_CODE, values, np.nan).astype(np.float32)

    @classmethod
    def from_block(cls, codes: np.ndarray, block: _Block) -> Moment:
        # Level-II gives value = (code - offset) / scale.
        return cls(
            codes,
            block.first_gate_m,
            block.gate_step_m,
            1.0 / block.scale,
            -block.offset / block.scale,
        )


@dataclass(frozen=True)
class _Cut:
    """What the message headers say about one sweep of the volume, before reading data."""

    index: int  # sweep number in the file (counting from 0)
    fixed_angle: float
    elevation_number: int
    moments: frozenset[str]
    nyquist_velocity_ms: float
    radial_width_deg: float  # NaN when the headers do not say
    complete: bool = True  # False when the file ends inside this sweep
    radials: tuple[_Radial, ...] = field(default=(), repr=False, compare=False)

    @property
    def has_polarimetry(self) -> bool:
        return any(name in self.moments for name in POLARIMETRIC_FIELDS)

    @property
    def has_doppler(self) -> bool:
        return "VRADH" in self.moments


@dataclass(frozen=True)
class CutData:
    """A cut as the merge sees it: azimuths of all its radials, and a reader for some.

    ``read(rows, names)`` returns the moments ``names`` (those the cut has) for the radials
    ``rows`` (indices into ``azimuth_deg``), so only the radials used are decoded.
    """

    azimuth_deg: np.ndarray
    read: Callable[[np.ndarray, Sequence[str]], dict[str, Moment]]


# ------------------------------------------------------------------------- file access
#: What a radial's moment may span: NEXRAD gates reach 460 km (1840 gates of 250 m); these
#: bounds leave room for other Level-II writers and refuse what no radar records.
_MAX_GATES = 4000
_MAX_RANGE_M = 1_000_000.0


@dataclass(frozen=True)
class _Volume:
    """The cuts read from a volume (possibly not all of them) and its station name."""

    cuts: list[_Cut]
    icao: str


def _radial(record: bytes, at: int, msg_type: int) -> _Radial:
    """Unpack the header of one radial message (type 1 or 31)."""
    body = at + MSG_HEADER.size
    if msg_type == 31:
        h = _MSG31.unpack_from(record, body)
        ms, date, azimuth, status, number, elevation = h[1], h[2], h[4], h[9], h[10], h[12]
    else:
        h = _MSG1.unpack_from(record, body)
        ms, date, status, number = h[0], h[1], h[5], h[7]
        azimuth, elevation = h[3] * _MSG1_ANGLE_DEG, h[6] * _MSG1_ANGLE_DEG
    if not (math.isfinite(azimuth) and 0.0 <= azimuth < 360.0):
        raise DamagedRecord(f"azimuth {azimuth!r} deg is not in [0, 360)")
    if not (math.isfinite(elevation) and -10.0 <= elevation <= 95.0):
        raise DamagedRecord(f"elevation {elevation!r} deg is not in [-10, 95]")
    # The date counts days from 1970-01-01 as day 1.
    time_ms = (int(date) - 1) * 86_400_000 + int(ms)
    return _Radial(
        record,
        at,
        msg_type == 1,
        int(status),
        int(number),
        float(azimuth),
        float(elevation),
        time_ms,
    )


def _vcp_angles(record: bytes, at: int) -> list[float]:
    """Fixed angles (deg) of the cuts in a message 5, in elevation-number order."""
    body = at + MSG_HEADER.size
    try:
        count = _MSG5.unpack_from(record, body)[3]
        if not 0 < count <= _MAX_VCP_CUTS:
            return []  # maintenance VCPs carry garbage here
        first = body + _MSG5.size
        return [
            struct.unpack_from(">H", record, first + i * _MSG5_CUT_BYTES)[0] * _MSG5_ANGLE_DEG
            for i in range(count)
        ]
    except struct.error:
        return []


def _wanted_elevation_numbers(vcp: list[float], elevation_deg: float) -> frozenset[int] | None:
    """Elevation numbers whose VCP angle is the one nearest the request, if the VCP says."""
    if not vcp:
        return None
    distance = np.abs(np.asarray(vcp) - elevation_deg)
    if distance.min() > _MAX_ELEVATION_MISMATCH_DEG:
        return None  # let the full scan produce the error listing the cuts
    nearest = vcp[int(np.argmin(distance))]
    return frozenset(i + 1 for i, a in enumerate(vcp) if abs(a - nearest) <= _SAME_ELEVATION_DEG)


def scan_volume(path: Path, elevation_deg: float) -> _Volume:
    """Read the message headers up to the end of the cuts at ``elevation_deg``.

    Cuts follow each other in elevation-number order. When the VCP (message 5, in the
    metadata before the first radial) gives the elevation numbers of the wanted angle, the
    scan stops at the first radial of the cut after the first run of them, without
    decompressing the rest of the file; otherwise every cut's headers are read.
    """
    raw = open_volume(path)
    icao = VOLUME_HEADER.unpack_from(raw)[4].decode("ascii", "replace").strip("\x00 ")
    vcp: list[float] = []
    wanted: frozenset[int] | None = None
    groups: list[tuple[list[_Radial], bool]] = []  # radials of each cut, and complete
    current: list[_Radial] | None = None
    truncated = Truncation()
    try:
        for record, at, msg_type in messages(records(raw, path, truncated), truncated):
            if msg_type == 5 and not vcp and not groups and current is None:
                vcp = _vcp_angles(record, at)
                wanted = _wanted_elevation_numbers(vcp, elevation_deg)
                continue
            if msg_type not in (1, 31):
                continue
            try:
                radial = _radial(record, at, msg_type)
            except DamagedRecord as err:
                n = sum(len(g[0]) for g in groups) + len(current or []) + 1
                raise ValueError(
                    f"{path}: radial {n} of the file (message {msg_type}) is damaged: {err}; "
                    "refusing the file rather than placing that radial"
                ) from None
            if radial.status in _CUT_START:
                if current is not None:
                    groups.append((current, False))  # a cut that never ended
                if (
                    wanted is not None
                    and radial.elevation_number not in wanted
                    and any(g[0][0].elevation_number in wanted for g in groups)
                ):
                    current = None
                    break  # past the wanted cuts
                current = []
            if current is None:
                continue  # radials before the first start of a cut belong to no cut
            current.append(radial)
            if radial.status in _CUT_END:
                groups.append((current, True))
                current = None
    except struct.error as err:
        raise ValueError(f"{path}: could not decode the Level-II headers ({err!r})") from err
    if current:
        groups.append((current, False))
    if truncated.at_byte is not None:
        size = (
            f" after {len(raw):,} bytes (decompressed)"
            if truncated.at_byte < 0
            else (f" at byte {path.stat().st_size:,}")
        )
        if not groups:
            raise ValueError(f"{path} is truncated: the file ends{size}, before any radial")
        last, complete = groups[-1]
        angle = float(np.median([r.elevation_deg for r in last]))
        needed = (
            last[0].elevation_number in wanted
            if wanted is not None
            else abs(angle - elevation_deg) <= _MAX_ELEVATION_MISMATCH_DEG
        )
        if not complete and needed:
            raise ValueError(
                f"{path} is truncated: the file ends{size}, inside the {angle:.2f} deg cut "
                f"after its radial {len(last)} (azimuth {last[-1].azimuth_deg:.1f} deg), so "
                "that cut is incomplete; fetch the whole file again"
            )
    if not groups:
        raise ValueError(f"{path}: the Level-II volume holds no radial data")
    try:
        cuts = [
            _describe_cut(i, radials, vcp, complete) for i, (radials, complete) in enumerate(groups)
        ]
    except struct.error as err:
        raise ValueError(f"{path}: could not decode the Level-II headers ({err!r})") from err
    except DamagedRecord as err:
        raise ValueError(f"{path}: a damaged record: {err}; refusing the file") from None
    return _Volume(cuts, icao)


def _blocks(r: _Radial) -> dict[str, _Block]:
    """The moment data blocks of one radial, by field name."""
    body = r.at + MSG_HEADER.size
    if r.legacy:
        h = _MSG1.unpack_from(r.record, body)
        sur_first, dop_first, sur_step, dop_step, sur_n, dop_n = h[8:14]
        ref_ptr, vel_ptr, sw_ptr, resolution = h[16:20]
        # ICD 2620002: reflectivity (N - 66) / 2 dBZ; velocity (N - 129) / 2 m/s, or
        # N - 129 at 1 m/s resolution (code 4); width (N - 129) / 2 m/s.
        slots = [
            ("DBZH", ref_ptr, sur_n, sur_first, sur_step, 2.0, 66.0),
            ("VRADH", vel_ptr, dop_n, dop_first, dop_step, 1.0 if resolution == 4 else 2.0, 129.0),
            ("WRADH", sw_ptr, dop_n, dop_first, dop_step, 2.0, 129.0),
        ]
        return {
            name: _checked(
                r, name, _Block(body + ptr, n, float(first), float(step), 8, scale, offset)
            )
            for name, ptr, n, first, step, scale, offset in slots
            if ptr and n
        }
    out: dict[str, _Block] = {}
    for ptr in _block_pointers(r):
        block_at = body + ptr
        if r.record[block_at : block_at + 1] != b"D":
            continue
        name = _MOMENT_NAMES.get(r.record[block_at + 1 : block_at + 4].decode("ascii", "replace"))
        if name is None:
            continue  # CFP and anything newer
        _, _, n, first, step, _, _, _, word, scale, offset = _GENERIC_BLOCK.unpack_from(
            r.record, block_at
        )
        out[name] = _checked(
            r,
            name,
            _Block(
                block_at + _GENERIC_BLOCK.size, n, float(first), float(step), word, scale, offset
            ),
        )
    return out


def _checked(r: _Radial, name: str, block: _Block) -> _Block:
    """Refuse a moment block whose geometry or scaling no radar records (a damaged record)."""
    where = f"{name} of the radial at azimuth {r.azimuth_deg:.2f} deg (cut {r.elevation_number})"
    end = block.first_gate_m + block.gate_step_m * block.ngates
    problem = None
    if not 0 < block.ngates <= _MAX_GATES:
        problem = f"{block.ngates} gates (at most {_MAX_GATES})"
    elif not 0 < block.gate_step_m <= 5000 or not abs(block.first_gate_m) <= 50_000:
        problem = f"gates from {block.first_gate_m:g} m every {block.gate_step_m:g} m"
    elif end > _MAX_RANGE_M:
        problem = (
            f"{block.ngates} gates reach {end / 1000:,.0f} km (at most {_MAX_RANGE_M / 1000:,.0f})"
        )
    elif block.word_size in (8, 16) and block.data_at + block.ngates * block.word_size // 8 > len(
        r.record
    ):
        problem = "its data run past the end of its record"
    elif not (math.isfinite(block.scale) and block.scale != 0 and math.isfinite(block.offset)):
        problem = f"scale {block.scale!r} and offset {block.offset!r}"
    if problem:
        raise DamagedRecord(f"{where}: {problem}")
    return block


def _block_pointers(r: _Radial) -> tuple[int, ...]:
    """The non-zero data block pointers of a message 31 (offsets from its body)."""
    body = r.at + MSG_HEADER.size
    count = min(_MSG31.unpack_from(r.record, body)[-1], _MAX_BLOCKS)
    pointers = struct.unpack_from(f">{count}I", r.record, body + _MSG31.size)
    return tuple(p for p in pointers if p > 0)


def _constant_block(r: _Radial, kind: bytes, layout: struct.Struct) -> tuple | None:
    """Unpack a message 31 constant block ("RVOL", "RRAD") of a radial, if it has one."""
    if r.legacy:
        return None
    body = r.at + MSG_HEADER.size
    for ptr in _block_pointers(r):
        if r.record[body + ptr : body + ptr + 4] == kind:
            return layout.unpack_from(r.record, body + ptr)
    return None


def _describe_cut(
    index: int, radials: list[_Radial], vcp: list[float], complete: bool = True
) -> _Cut:
    """Summarise one sweep from its radial headers and its first radial's data blocks."""
    first = radials[0]
    measured = float(np.median([r.elevation_deg for r in radials]))
    fixed = measured
    if 1 <= first.elevation_number <= len(vcp):
        vcp_angle = float(vcp[first.elevation_number - 1])
        # Message 5 can be garbage (e.g. maintenance VCPs); trust it only near the antenna.
        if abs(vcp_angle - measured) <= _MAX_ELEVATION_MISMATCH_DEG:
            fixed = vcp_angle

    # A cut's moments are what its radials carry (the first and 16 more across the cut; the
    # radials a run reads are all checked when read): a first radial that disagrees with the
    # rest is a damaged record, not a single-polarisation cut.
    sample = [first, *radials[1 :: max(1, len(radials) // 16)]]
    carried = [frozenset(_blocks(r)) for r in sample]
    moments, count = Counter(carried).most_common(1)[0]
    if carried[0] != moments and count > len(sample) // 2:
        raise DamagedRecord(
            f"the first radial of cut {first.elevation_number} (azimuth {first.azimuth_deg:.2f} "
            f"deg) carries {', '.join(sorted(carried[0])) or 'no moment'} where {count} of "
            f"{len(sample)} radials sampled across the cut carry {', '.join(sorted(moments))}"
        )
    if first.legacy:
        nyquist_raw = _MSG1.unpack_from(first.record, first.at + MSG_HEADER.size)[-1]
        radial_width = 1.0  # message 1 predates super-resolution
    else:
        rad = _constant_block(first, b"RRAD", _RADIAL_BLOCK)
        nyquist_raw = rad[-1] if rad else 0
        resolution = _MSG31.unpack_from(first.record, first.at + MSG_HEADER.size)[8]
        radial_width = {1: 0.5, 2: 1.0}.get(int(resolution), np.nan)
    # Both messages store the Nyquist velocity in 0.01 m/s; 0 means not recorded.
    nyquist = nyquist_raw / 100.0 if nyquist_raw else np.nan
    return _Cut(
        index,
        fixed,
        first.elevation_number,
        moments,
        float(nyquist),
        float(radial_width),
        complete,
        tuple(radials),
    )


def time_order(radials: Sequence[_Radial]) -> tuple[_Radial, ...]:
    """Radials sorted by collection time (stable: file order among equal times)."""
    order = np.argsort([r.time_ms for r in radials], kind="stable")
    return tuple(radials[i] for i in order)


def cut_data(radials: Sequence[_Radial]) -> CutData:
    """Azimuths of a cut's radials and a reader that decodes only the radials asked for."""

    def read(rows: np.ndarray, names: Sequence[str]) -> dict[str, Moment]:
        return _read_moments([radials[i] for i in rows], radials[0], names)

    return CutData(np.array([r.azimuth_deg for r in radials], dtype=np.float64), read)


def _read_moments(
    radials: Sequence[_Radial], reference: _Radial, names: Sequence[str]
) -> dict[str, Moment]:
    """Codes of the moments ``names`` for ``radials``, on the gates of ``reference``.

    The cut's first radial (``reference``) fixes each moment's gate geometry, scale and
    offset, as the ICD has them constant through a cut; a radial with fewer gates is padded
    with code 0 (no data), one with more is cut to length.
    """
    layout = _blocks(reference)
    wanted = [n for n in names if n in layout]
    codes = {
        n: np.zeros(
            (len(radials), layout[n].ngates),
            dtype=np.uint16 if layout[n].word_size == 16 else np.uint8,
        )
        for n in wanted
    }
    for row, radial in enumerate(radials):
        blocks = _blocks(radial)
        for name in wanted:
            block = blocks.get(name)
            if block is None:
                continue
            width = {8: 1, 16: 2}.get(block.word_size)
            if width is None:
                raise ValueError(f"unsupported {block.word_size}-bit words in {name}")
            n = min(block.ngates, codes[name].shape[1])
            values = np.frombuffer(radial.record, dtype=f">u{width}", count=n, offset=block.data_at)
            codes[name][row, :n] = values
    out = {}
    for name in wanted:
        c = codes[name]
        if layout[name].word_size == 16 and name in _CODE_MASK_16:
            c &= np.uint16(_CODE_MASK_16[name])
        out[name] = Moment.from_block(c, layout[name])
    return out


def choose_cuts(cuts: Sequence[_Cut], elevation_deg: float, path: Path) -> tuple[_Cut, _Cut | None]:
    """Pick the surveillance cut and, for a split elevation, its Doppler partner."""
    distance = [abs(c.fixed_angle - elevation_deg) for c in cuts]
    nearest = cuts[int(np.argmin(distance))]
    if min(distance) > _MAX_ELEVATION_MISMATCH_DEG:
        angles = ", ".join(f"{a:.2f}" for a in sorted({round(c.fixed_angle, 2) for c in cuts}))
        raise ValueError(
            f"{path}: no cut within {_MAX_ELEVATION_MISMATCH_DEG} deg of elevation "
            f"{elevation_deg} deg; available fixed angles (deg): {angles}"
        )
    # Sweep order matters: SAILS/MRLE volumes revisit the lowest elevation later, and the
    # first pair is the one recorded together.
    group = [c for c in cuts if abs(c.fixed_angle - nearest.fixed_angle) <= _SAME_ELEVATION_DEG]

    with_reflectivity = [c for c in group if "DBZH" in c.moments]
    if not with_reflectivity:
        raise ValueError(
            f"{path}: the {nearest.fixed_angle:.2f} deg cuts carry no reflectivity, so no "
            "truth sweep can be built there"
        )
    # The long-PRT cut is the one with dual-pol moments, or (single-pol files) the one
    # without velocity; its reflectivity is unambiguous to the longest range.
    surveillance = next(
        (c for c in with_reflectivity if c.has_polarimetry),
        next((c for c in with_reflectivity if not c.has_doppler), with_reflectivity[0]),
    )
    if surveillance.has_doppler:
        return surveillance, None
    partners = [c for c in group if c.has_doppler and c.index != surveillance.index]
    later = [c for c in partners if c.index > surveillance.index]
    if later:
        return surveillance, later[0]
    return surveillance, (partners[-1] if partners else None)


def site_attributes(icao: str, first: _Radial, used: Sequence[_Radial]) -> dict[str, Any]:
    """Radar site from the first radial's volume block; start time of the cuts used."""
    vol = _constant_block(first, b"RVOL", _VOLUME_BLOCK)
    # Message 1 carries no site position; 0 is what xradar and Py-ART report there too.
    lat, lon, alt = (vol[4], vol[5], vol[6] + vol[7]) if vol else (0.0, 0.0, 0.0)
    start = np.datetime64(min(r.time_ms for r in used), "ms")
    return {
        "latitude": float(lat),
        "longitude": float(lon),
        "altitude": float(alt),
        "instrument_name": icao,
        "time_coverage_start": str(start)[:19] + "Z",
    }
