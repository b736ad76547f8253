"""Read one elevation of a NEXRAD Level-II volume as a cleaned "truth" sweep.

The simulator needs, for one elevation angle, every moment the WSR-88D measured on a
common polar grid: reflectivity and the dual-polarisation moments from the surveillance
(long PRT) cut, radial velocity and spectrum width from the Doppler (short PRT) cut that
follows it at the same elevation. :func:`read_truth_sweep` finds those cuts, decodes only
them (and, with a sector, only its radials), masks the Level-II "no data" codes, merges the
two cuts by azimuth and by range, and cleans values outside their physical range.

Notes
-----
The module decodes the Level-II messages itself (ICD 2620010 for message 31, 2620002 for
the legacy message 1), for three reasons:

- **Cost.** The volume is stored as bzip2 records of about 120 radials each, in scan order.
  Only the records up to the end of the wanted cuts are decompressed (the VCP in message 5
  says which elevation numbers those are), and only the wanted radials are decoded: the
  0.5 deg cuts of a 28 MB volume take about a quarter of the records.
- **Legacy files.** xradar 0.12 reads message 1's range to the first gate as unsigned, so
  the Doppler gates of a legacy split cut (first gate -375 m, stored as 65161) land 65 km
  downrange; it looks the width up as ``"SW "`` where message 1 names it ``"SW"`` (and would
  decode it with offset 192 instead of 129); and it puts every moment of a cut on the range
  axis of the first one (1 km reflectivity gates for 250 m velocity gates). Here each
  moment keeps its own gate geometry and is put on the reflectivity gates by range.
- **Masking.** Codes 0 (below threshold) and 1 (range folded) are masked exactly, by code,
  before scale and offset are applied; xradar 0.12 decodes them as ordinary numbers
  (for example -33 dBZ, -8 dB, 0.2017, -0.705 deg, -64.5 m/s).
"""

from __future__ import annotations

import bz2
import gzip
import struct
import warnings
import zlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "DOPPLER_FIELDS",
    "FIELD_NAMES",
    "POLARIMETRIC_FIELDS",
    "SURVEILLANCE_FIELDS",
    "TruthSweep",
    "read_truth_sweep",
]

#: Every moment a truth sweep can carry, in xradar (ODIM-like) names.
FIELD_NAMES: tuple[str, ...] = ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH")
#: Moments whose presence makes a sweep dual-polarisation.
POLARIMETRIC_FIELDS: tuple[str, ...] = ("ZDR", "RHOHV", "PHIDP")
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

# Physical limits beyond which a decoded value is garbage rather than a measurement.
_DBZH_LIMITS = (-35.0, 100.0)
_ZDR_LIMITS = (-8.0, 8.0)
_RHOHV_LIMITS = (0.0, 1.1)  # open below, closed above: rho > 1 is a real estimate

# ------------------------------------------------------------------ Level-II layout
# Level-II archives start with "AR2V00nn." (build 10+) or "ARCHIVE2." (older builds).
_VOLUME_MAGIC = (b"AR2V", b"ARCHIVE2")
_VOLUME_HEADER = struct.Struct(">9s3sII4s")  # tape, extension, date, time, ICAO
_VOLUME_HEADER_BYTES = 24
# Each message is preceded by 12 bytes of channel terminal manager (CTM) data.
_CTM_BYTES = 12
# Every message but 31 fills one fixed frame; so does each of the metadata messages
# (15, 13, 18, 3, 5, 2) that open a volume.
_FRAME_BYTES = 2432
_METADATA_FRAMES = 134
# size (halfwords, header included), channels, type, sequence, date, ms, segments, segment
_MSG_HEADER = struct.Struct(">HBBHHIHH")
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


@dataclass(frozen=True)
class TruthSweep:
    """One elevation of a Level-II volume with all available moments on one grid.

    Attributes
    ----------
    azimuth_deg : numpy.ndarray
        float64, shape (radial,). Azimuth of each radial in [0, 360), increasing along the
        requested sector, i.e. clockwise from its start (a sector through north runs
        330 ... 359.x, 0 ... 30).
    elevation_deg : float
        Mean measured elevation of the surveillance cut.
    range_m : numpy.ndarray
        float64, shape (gate,). Range to the centres of the surveillance cut's reflectivity
        gates; every field is on these gates.
    radial_width_deg : float
        Nominal azimuth spacing of the radials (0.5 for super-resolution cuts).
    gate_width_m : float
        Gate spacing in metres.
    fields : dict of str to numpy.ndarray
        float32 arrays of shape (radial, gate), NaN where there is no valid data. Keys are
        among ``DBZH ZDR RHOHV PHIDP VRADH WRADH``; a moment the file does not carry is
        absent rather than all-NaN.
    nyquist_velocity_ms : float
        Nyquist velocity of the cut the velocities come from, NaN if unknown. VRADH is
        kept as measured, so it may be folded at this velocity.
    site : dict
        ``latitude``, ``longitude`` (deg), ``altitude`` (m), ``instrument_name`` and
        ``time_coverage_start`` (ISO string). Message 1 carries no site: its latitude,
        longitude and altitude are 0, as xradar reports them.
    source : str
        File name the sweep was read from.
    """

    azimuth_deg: np.ndarray
    elevation_deg: float
    range_m: np.ndarray
    radial_width_deg: float
    gate_width_m: float
    fields: dict[str, np.ndarray]
    nyquist_velocity_ms: float
    site: dict[str, Any]
    source: str

    def __post_init__(self) -> None:
        # A mismatched grid would only surface far downstream as a broadcasting error.
        shape = (self.azimuth_deg.size, self.range_m.size)
        for name, values in self.fields.items():
            if values.shape != shape:
                raise ValueError(f"field {name} has shape {values.shape}, expected {shape}")

    @property
    def polarimetric(self) -> bool:
        """bool: True when ZDR, RHOHV and PHIDP are all present."""
        return all(name in self.fields for name in POLARIMETRIC_FIELDS)

    @property
    def shape(self) -> tuple[int, int]:
        """tuple of int: (number of radials, number of gates)."""
        return (self.azimuth_deg.size, self.range_m.size)


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
class _Moment:
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
    def from_block(cls, codes: np.ndarray, block: _Block) -> _Moment:
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
class _CutData:
    """A cut as the merge sees it: azimuths of all its radials, and a reader for some.

    ``read(rows, names)`` returns the moments ``names`` (those the cut has) for the radials
    ``rows`` (indices into ``azimuth_deg``), so only the radials used are decoded.
    """

    azimuth_deg: np.ndarray
    read: Callable[[np.ndarray, Sequence[str]], dict[str, _Moment]]


# --------------------------------------------------------------------------- public API


def read_truth_sweep(
    path: str | PathLike[str],
    elevation_deg: float = 0.5,
    sector_deg: tuple[float, float] | None = None,
    margin_deg: float = 0.0,
) -> TruthSweep:
    """Read the cuts of one elevation from a NEXRAD Level-II file as a truth sweep.

    Parameters
    ----------
    path : str or os.PathLike
        Level-II (Archive II) volume, message 31 or legacy message 1; bzip2-compressed
        records, uncompressed records and a whole-file gzip or bzip2 wrapper are all
        accepted.
    elevation_deg : float, optional
        Wanted elevation; the cuts whose VCP fixed angle is nearest are used.
    sector_deg : tuple of float, optional
        ``(az0, az1)``: keep radials from ``az0`` clockwise to ``az1`` (degrees; wrapping
        through north is allowed, ``(0, 360)`` is the full circle). None keeps all radials.
        Only the radials kept are decoded.
    margin_deg : float, optional
        Widen the sector by this much on both sides (e.g. for a beam footprint).

    Returns
    -------
    TruthSweep
        Radials in clockwise order from the sector start, fields cleaned as described in
        Notes.

    Warns
    -----
    UserWarning
        If the file ends inside one of the cuts used (truncated or real-time volume).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file is not a Level-II volume, cannot be decoded, holds no cut within 1 deg
        of ``elevation_deg``, or no radial lies in the sector.

    Notes
    -----
    Reading stops after the last record of the wanted cuts when the volume's VCP
    (message 5) names them; without a VCP (common in message 1 files) every record's
    headers are read, but still only the wanted radials are decoded.

    Split cuts are merged: DBZH/ZDR/RHOHV/PHIDP come from the surveillance cut, VRADH/WRADH
    from the Doppler cut at the same elevation, matched to each surveillance radial by the
    nearest azimuth within half a radial spacing. The grid is the surveillance cut's
    reflectivity gates; every other moment is put on it by range (see
    :func:`_doppler_on_grid`), so Doppler gates of a different size or first range (1 km
    reflectivity and 250 m velocity gates in message 1) land where they were measured.
    Beyond the Doppler cut's range the Doppler moments are NaN. A cut that carries all
    moments is used alone.

    Cleaning: Level-II codes 0 and 1 -> NaN; DBZH outside [-35, 100] dBZ, ZDR outside
    [-8, 8] dB, RHOHV outside (0, 1.1] and negative WRADH -> NaN; PHIDP wrapped into
    [0, 360); RHOHV above 1 and folded VRADH are kept as measured. Wherever DBZH is NaN
    every other moment is NaN too.
    """
    path = Path(path)
    sector, margin = _check_sector(sector_deg, margin_deg)
    volume = _scan_volume(path, float(elevation_deg))
    surveillance, doppler = _choose_cuts(volume.cuts, float(elevation_deg), path)

    for cut in (surveillance, doppler):
        if cut is not None and not cut.complete:
            # Real-time chunks and cut-off downloads end mid-sweep; the result is still usable
            # but lacks radials, which the caller should know.
            warnings.warn(
                f"{path}: sweep {cut.index} ({cut.fixed_angle:.2f} deg) is incomplete; "
                "the truth lacks the radials missing from the file",
                UserWarning,
                stacklevel=2,
            )

    surv_radials = _time_order(surveillance.radials)
    radial_width = surveillance.radial_width_deg
    if not np.isfinite(radial_width):
        radial_width = _nominal_spacing(np.array([r.azimuth_deg for r in surv_radials]))
    nyquist_cut = surveillance if doppler is None else doppler
    try:
        azimuth, range_m, fields = _assemble(
            _cut_data(surv_radials),
            None if doppler is None else _cut_data(_time_order(doppler.radials)),
            radial_width_deg=radial_width,
            sector_deg=sector,
            margin_deg=margin,
            nyquist_velocity_ms=nyquist_cut.nyquist_velocity_ms,
        )
    except (struct.error, IndexError, ValueError) as err:
        # A block pointer or gate count that runs past its message: a corrupt record.
        wanted = [c.index for c in (surveillance, doppler) if c is not None]
        raise ValueError(f"{path}: could not decode sweeps {wanted} ({err!r})") from err
    if azimuth.size == 0:
        raise ValueError(
            f"{path}: no radial of the {surveillance.fixed_angle:.2f} deg cut lies in sector "
            f"{sector_deg} with margin {margin_deg} deg"
        )

    used = surv_radials + (() if doppler is None else doppler.radials)
    return TruthSweep(
        azimuth_deg=azimuth,
        elevation_deg=float(np.mean([r.elevation_deg for r in surv_radials])),
        range_m=range_m,
        radial_width_deg=float(radial_width),
        gate_width_m=_gate_width(range_m),
        fields=fields,
        nyquist_velocity_ms=nyquist_cut.nyquist_velocity_ms,
        site=_site(volume.icao, surv_radials[0], used),
        source=path.name,
    )


# ------------------------------------------------------------------------- file access


@dataclass(frozen=True)
class _Volume:
    """The cuts read from a volume (possibly not all of them) and its station name."""

    cuts: list[_Cut]
    icao: str


def _open_volume(path: Path) -> bytes:
    """Return the file's bytes with any whole-file gzip/bzip2 wrapper removed, validated."""
    if not path.is_file():
        raise FileNotFoundError(f"NEXRAD Level-II file not found (no such file): {path}")
    raw = path.read_bytes()
    try:
        # Archive copies are often wrapped whole in gzip (.gz) or bzip2 (.bz2).
        if raw[:2] == b"\x1f\x8b":
            raw = gzip.decompress(raw)
        elif raw[:3] == b"BZh":
            raw = bz2.decompress(raw)
    except (OSError, EOFError, zlib.error) as err:
        raise ValueError(f"{path}: corrupt gzip/bzip2 wrapper ({err})") from err
    if not raw.startswith(_VOLUME_MAGIC) or len(raw) < _VOLUME_HEADER_BYTES:
        raise ValueError(
            f"{path} is not a NEXRAD Level-II (Archive II) volume: expected a 24-byte volume "
            f"header starting with 'AR2V' or 'ARCHIVE2', found {raw[:8]!r}"
        )
    return raw


class _Truncation:
    """Where a truncated file ends: set by :func:`_records` and :func:`_messages`."""

    def __init__(self) -> None:
        self.at_byte: int | None = None


def _records(raw: bytes, path: Path, cut: _Truncation | None = None) -> Iterator[bytes]:
    """The volume's messages as decompressed records, one at a time, in file order.

    A compressed volume is a sequence of records, each a 4-byte big-endian length (negative
    for the last one) followed by one bzip2 stream; a plain volume is one record. Records
    are decompressed only when asked for, so a reader that stops early saves the rest.
    A record that runs past the end of the file (a cut-off download) is noted in ``cut``.
    """
    first = _VOLUME_HEADER_BYTES
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
            yield bz2.BZ2Decompressor().decompress(view[pos + 4 : pos + 4 + size])
        except OSError as err:
            raise ValueError(f"{path}: corrupt bzip2 record at byte {pos} ({err})") from err
        pos += 4 + size
    if cut is not None and 0 < len(raw) - pos < 4:
        cut.at_byte = len(raw)


def _load_volume_bytes(path: Path) -> bytes:
    """The whole volume as uncompressed Level-II bytes (volume header + plain records)."""
    raw = _open_volume(path)
    volume = bytearray(raw[:_VOLUME_HEADER_BYTES] + b"".join(_records(raw, path)))
    # Readers tell compressed from plain volumes by bytes 24..27; in plain records those are
    # the first message's CTM bytes, which Archive II leaves unused, so zeroing them is safe.
    volume[_VOLUME_HEADER_BYTES : _VOLUME_HEADER_BYTES + _CTM_BYTES] = bytes(_CTM_BYTES)
    return bytes(volume)


def _messages(
    records: Iterator[bytes], cut: _Truncation | None = None
) -> Iterator[tuple[bytes, int, int]]:
    """``(record, offset of the message header, message type)`` of every whole message.

    A message cut short (the file ends inside it) is noted in ``cut``.
    """
    count = 0
    for record in records:
        pos, end = 0, len(record)
        while pos + _CTM_BYTES + _MSG_HEADER.size <= end:
            at = pos + _CTM_BYTES
            size, _, msg_type = _MSG_HEADER.unpack_from(record, at)[:3]
            length = _FRAME_BYTES
            if count >= _METADATA_FRAMES or msg_type == 31:
                # Message 31 has its own length; others fill at least a frame.
                variable = _CTM_BYTES + 2 * size
                length = variable if msg_type == 31 else max(variable, _FRAME_BYTES)
                if length <= _CTM_BYTES + _MSG_HEADER.size:
                    length = _FRAME_BYTES  # a zero-size message 31 is padding
            if pos + length > end:
                if cut is not None and cut.at_byte is None:
                    cut.at_byte = -1  # somewhere in the last record
                break  # cut short: a truncated record
            count += 1
            if msg_type != 0:  # type 0 frames are padding
                yield record, at, msg_type
            pos += length


def _radial(record: bytes, at: int, msg_type: int) -> _Radial:
    """Unpack the header of one radial message (type 1 or 31)."""
    body = at + _MSG_HEADER.size
    if msg_type == 31:
        h = _MSG31.unpack_from(record, body)
        ms, date, azimuth, status, number, elevation = h[1], h[2], h[4], h[9], h[10], h[12]
    else:
        h = _MSG1.unpack_from(record, body)
        ms, date, status, number = h[0], h[1], h[5], h[7]
        azimuth, elevation = h[3] * _MSG1_ANGLE_DEG, h[6] * _MSG1_ANGLE_DEG
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
    body = at + _MSG_HEADER.size
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


def _scan_volume(path: Path, elevation_deg: float) -> _Volume:
    """Read the message headers up to the end of the cuts at ``elevation_deg``.

    Cuts follow each other in elevation-number order. When the VCP (message 5, in the
    metadata before the first radial) gives the elevation numbers of the wanted angle, the
    scan stops at the first radial of the cut after the first run of them, without
    decompressing the rest of the file; otherwise every cut's headers are read.
    """
    raw = _open_volume(path)
    icao = _VOLUME_HEADER.unpack_from(raw)[4].decode("ascii", "replace").strip("\x00 ")
    vcp: list[float] = []
    wanted: frozenset[int] | None = None
    groups: list[tuple[list[_Radial], bool]] = []  # radials of each cut, and complete
    current: list[_Radial] | None = None
    truncated = _Truncation()
    try:
        for record, at, msg_type in _messages(_records(raw, path, truncated), truncated):
            if msg_type == 5 and not vcp and not groups and current is None:
                vcp = _vcp_angles(record, at)
                wanted = _wanted_elevation_numbers(vcp, elevation_deg)
                continue
            if msg_type not in (1, 31):
                continue
            radial = _radial(record, at, msg_type)
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
    return _Volume(cuts, icao)


def _blocks(r: _Radial) -> dict[str, _Block]:
    """The moment data blocks of one radial, by field name."""
    body = r.at + _MSG_HEADER.size
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
            name: _Block(body + ptr, n, float(first), float(step), 8, scale, offset)
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
        out[name] = _Block(
            block_at + _GENERIC_BLOCK.size, n, float(first), float(step), word, scale, offset
        )
    return out


def _block_pointers(r: _Radial) -> tuple[int, ...]:
    """The non-zero data block pointers of a message 31 (offsets from its body)."""
    body = r.at + _MSG_HEADER.size
    count = min(_MSG31.unpack_from(r.record, body)[-1], _MAX_BLOCKS)
    pointers = struct.unpack_from(f">{count}I", r.record, body + _MSG31.size)
    return tuple(p for p in pointers if p > 0)


def _constant_block(r: _Radial, kind: bytes, layout: struct.Struct) -> tuple | None:
    """Unpack a message 31 constant block ("RVOL", "RRAD") of a radial, if it has one."""
    if r.legacy:
        return None
    body = r.at + _MSG_HEADER.size
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

    moments = frozenset(_blocks(first))
    if first.legacy:
        nyquist_raw = _MSG1.unpack_from(first.record, first.at + _MSG_HEADER.size)[-1]
        radial_width = 1.0  # message 1 predates super-resolution
    else:
        rad = _constant_block(first, b"RRAD", _RADIAL_BLOCK)
        nyquist_raw = rad[-1] if rad else 0
        resolution = _MSG31.unpack_from(first.record, first.at + _MSG_HEADER.size)[8]
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


def _time_order(radials: Sequence[_Radial]) -> tuple[_Radial, ...]:
    """Radials sorted by collection time (stable: file order among equal times)."""
    order = np.argsort([r.time_ms for r in radials], kind="stable")
    return tuple(radials[i] for i in order)


def _cut_data(radials: Sequence[_Radial]) -> _CutData:
    """Azimuths of a cut's radials and a reader that decodes only the radials asked for."""

    def read(rows: np.ndarray, names: Sequence[str]) -> dict[str, _Moment]:
        return _read_moments([radials[i] for i in rows], radials[0], names)

    return _CutData(np.array([r.azimuth_deg for r in radials], dtype=np.float64), read)


def _read_moments(
    radials: Sequence[_Radial], reference: _Radial, names: Sequence[str]
) -> dict[str, _Moment]:
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
        out[name] = _Moment.from_block(c, layout[name])
    return out


def _choose_cuts(
    cuts: Sequence[_Cut], elevation_deg: float, path: Path
) -> tuple[_Cut, _Cut | None]:
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


def _site(icao: str, first: _Radial, used: Sequence[_Radial]) -> dict[str, Any]:
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


# ---------------------------------------------------------------------- data assembly


def _assemble(
    surveillance: _CutData,
    doppler: _CutData | None,
    *,
    radial_width_deg: float,
    sector_deg: tuple[float, float] | None,
    margin_deg: float,
    nyquist_velocity_ms: float = float("nan"),
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Merge the surveillance and Doppler cuts into cleaned, sector-cut fields.

    Radials come in time order. Only the surveillance radials in the sector, and the
    Doppler radials paired with them, are read.
    """
    azimuth = _wrap360(surveillance.azimuth_deg.astype(np.float64))
    keep = _drop_duplicate_radials(azimuth, radial_width_deg)
    order = keep[_sector_order(azimuth[keep], sector_deg, margin_deg)]
    azimuth = azimuth[order]

    own_names = SURVEILLANCE_FIELDS + (DOPPLER_FIELDS if doppler is None else ())
    own = surveillance.read(order, own_names)
    if "DBZH" not in own:
        raise ValueError("the surveillance cut has no reflectivity")
    grid = own["DBZH"]
    range_m = grid.first_gate_m + grid.gate_step_m * np.arange(grid.codes.shape[1])

    fields: dict[str, np.ndarray] = {}
    for name in SURVEILLANCE_FIELDS:
        if name in own:
            fields[name] = _on_grid(own[name], range_m, grid.gate_step_m)
    if doppler is None:
        # A cut that measured everything at once: its own radials, its own gates.
        fields.update(_doppler_on_grid(own, range_m, grid.gate_step_m, nyquist_velocity_ms))
    else:
        src_az = _wrap360(doppler.azimuth_deg.astype(np.float64))
        rows = _nearest_circular(azimuth, src_az, 0.5 * radial_width_deg)
        paired = rows >= 0
        needed = np.unique(rows[paired])
        moments = doppler.read(needed, DOPPLER_FIELDS)
        on_grid = _doppler_on_grid(moments, range_m, grid.gate_step_m, nyquist_velocity_ms)
        position = np.searchsorted(needed, rows[paired])
        for name, values in on_grid.items():
            out = np.full((azimuth.size, range_m.size), np.nan, dtype=np.float32)
            out[paired] = values[position]
            fields[name] = out
    return azimuth, range_m, _clean(fields)


def _cover_index(
    range_m: np.ndarray, first_gate_m: float, gate_step_m: float, n: int
) -> np.ndarray:
    """For each grid range, the source gate whose extent contains it, or -1."""
    k = np.floor((range_m - first_gate_m) / gate_step_m + 0.5).astype(np.intp)
    return np.where((k >= 0) & (k < n), k, -1)


def _on_grid(moment: _Moment, range_m: np.ndarray, grid_step_m: float) -> np.ndarray:
    """A moment's values on the grid gates: the source gate that covers each gate centre.

    On the same gates (every message 31 surveillance moment) this is the identity, NaN
    beyond the moment's last gate.
    """
    values = moment.decode()
    cols = _cover_index(range_m, moment.first_gate_m, moment.gate_step_m, values.shape[1])
    out = np.full((values.shape[0], range_m.size), np.nan, dtype=np.float32)
    out[:, cols >= 0] = values[:, cols[cols >= 0]]
    return out


def _doppler_on_grid(
    moments: dict[str, _Moment], range_m: np.ndarray, grid_step_m: float, nyquist_ms: float
) -> dict[str, np.ndarray]:
    """VRADH and WRADH (those present) on the grid gates, by range.

    Doppler gates as large as the grid gates or larger: each grid gate takes the Doppler gate
    that covers its centre (message 31: the same 250 m gates, so the identity).

    Finer Doppler gates (message 1: four 250 m velocity gates, centred -375, -125, 125 and
    375 m about each 1 km reflectivity gate): a grid gate stands for the whole 1 km volume,
    so it takes the mean over the Doppler gates whose centres lie inside it rather than one
    of them (the nearest would be a tie at the gate centre, and would throw away three
    quarters of the measurements). The velocity is a circular mean on the Nyquist interval,
    so gates folded at +-v_N average to the unfolded direction instead of to zero, and stays
    within the Nyquist interval like a measured one. The width is that of the sum of the
    sub-gate spectra (equal weights, for want of sub-gate reflectivity): the square root of
    the mean of w^2 plus the velocity spread about the mean. Gates with no valid sub-gate
    stay NaN.
    """
    out: dict[str, np.ndarray] = {}
    vel, width = moments.get("VRADH"), moments.get("WRADH")
    mean = None  # float64 mean velocity per grid gate, when averaged from finer gates
    for name, m in (("VRADH", vel), ("WRADH", width)):
        if m is not None and m.gate_step_m >= grid_step_m:
            out[name] = _on_grid(m, range_m, grid_step_m)
    if vel is not None and "VRADH" not in out:
        v, lo, hi, owner = _segments(vel, range_m, grid_step_m)
        out["VRADH"], mean = _velocity_mean(v, lo, hi, owner, nyquist_ms)
    if width is not None and "WRADH" not in out:
        w, lo, hi, owner = _segments(width, range_m, grid_step_m)
        spread_sq = np.zeros_like(w, dtype=np.float64)
        same_gates = vel is not None and (vel.first_gate_m, vel.gate_step_m) == (
            width.first_gate_m,
            width.gate_step_m,
        )
        if same_gates and mean is not None:
            v = vel.decode().astype(np.float64)
            inside = owner >= 0
            d = np.zeros_like(v)
            d[:, inside] = _velocity_difference(v[:, inside], mean[:, owner[inside]], nyquist_ms)
            spread_sq = np.where(np.isfinite(d), d * d, 0.0)
        w64 = w.astype(np.float64)
        ok = np.isfinite(w64)
        total = _segment_sum(np.where(ok, w64 * w64 + spread_sq, 0.0), lo, hi)
        count = _segment_sum(ok.astype(np.float64), lo, hi)
        with np.errstate(invalid="ignore", divide="ignore"):
            out["WRADH"] = np.sqrt(total / count).astype(np.float32)
    return out


def _segments(
    moment: _Moment, range_m: np.ndarray, grid_step_m: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Decoded values and, per grid gate, the run [lo, hi) of source gates inside it.

    Also returns the owning grid gate of each source gate (-1 outside the grid).
    """
    values = moment.decode()
    src = moment.first_gate_m + moment.gate_step_m * np.arange(values.shape[1])
    edges = np.append(range_m - 0.5 * grid_step_m, range_m[-1] + 0.5 * grid_step_m)
    bounds = np.searchsorted(src, edges, side="left")
    owner = np.searchsorted(edges, src, side="right") - 1
    owner[(owner < 0) | (owner >= range_m.size)] = -1
    return values, bounds[:-1], bounds[1:], owner


def _segment_sum(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Sums of x[:, lo[k]:hi[k]] for every k (0 for an empty run)."""
    return _segment_reduce(np.add, x, lo, hi, 0.0)


def _segment_reduce(
    op: np.ufunc, x: np.ndarray, lo: np.ndarray, hi: np.ndarray, empty: float
) -> np.ndarray:
    """``op`` reduced over x[:, lo[k]:hi[k]] for every k; the runs are adjacent and in order."""
    out = np.full((x.shape[0], lo.size), empty, dtype=np.float64)
    full = hi > lo
    if full.any():
        out[:, full] = op.reduceat(x[:, : hi[full][-1]], lo[full], axis=1)
    return out


def _velocity_mean(
    v: np.ndarray, lo: np.ndarray, hi: np.ndarray, owner: np.ndarray, nyquist_ms: float
) -> tuple[np.ndarray, np.ndarray]:
    """Mean velocity over each run of gates (circular on +-nyquist_ms when it is known).

    The mean is taken of the differences from one valid velocity of the run (the largest),
    folded into the Nyquist interval, and added back to it: one valid gate, or several
    equal ones, give exactly their value, and a value just beyond the Nyquist velocity (the
    0.5 m/s code steps allow it) is not flipped to the other end of the interval. The sum
    is folded back into the Nyquist interval (widened to the reference value).
    Returns the float32 mean and the float64 one (for the width's velocity spread).
    """
    v64 = v.astype(np.float64)
    ok = np.isfinite(v64)
    count = _segment_sum(ok.astype(np.float64), lo, hi)
    ref = _segment_reduce(np.fmax, v64, lo, hi, np.nan)
    inside = owner >= 0
    d = np.zeros_like(v64)
    d[:, inside] = _velocity_difference(v64[:, inside], ref[:, owner[inside]], nyquist_ms)
    d[~ok] = 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        if np.isfinite(nyquist_ms) and nyquist_ms > 0:
            phase = d * (np.pi / nyquist_ms)
            c = _segment_sum(np.where(ok, np.cos(phase), 0.0), lo, hi)
            s = _segment_sum(np.where(ok, np.sin(phase), 0.0), lo, hi)
            mean = ref + np.arctan2(s, c) * (nyquist_ms / np.pi)
            # Back into the Nyquist interval, which reaches as far as the reference does.
            mean = np.where(mean > np.maximum(ref, nyquist_ms), mean - 2 * nyquist_ms, mean)
            mean = np.where(mean < np.minimum(ref, -nyquist_ms), mean + 2 * nyquist_ms, mean)
        else:
            mean = ref + _segment_sum(d, lo, hi) / count
    mean = np.where(count > 0, mean, np.nan)
    return mean.astype(np.float32), mean


def _velocity_difference(a: np.ndarray, b: np.ndarray, nyquist_ms: float) -> np.ndarray:
    """a - b, folded into [-v_N, v_N) when the Nyquist velocity is known."""
    d = a - b
    if np.isfinite(nyquist_ms) and nyquist_ms > 0:
        d = np.mod(d + nyquist_ms, 2.0 * nyquist_ms) - nyquist_ms
    return d


def _clean(fields: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Replace physically impossible values by NaN and wrap PHIDP into [0, 360)."""
    out: dict[str, np.ndarray] = {}
    for name, values in fields.items():
        v = values.astype(np.float32, copy=True)
        if name == "DBZH":
            v[~((v >= _DBZH_LIMITS[0]) & (v <= _DBZH_LIMITS[1]))] = np.nan
        elif name == "ZDR":
            v[~((v >= _ZDR_LIMITS[0]) & (v <= _ZDR_LIMITS[1]))] = np.nan
        elif name == "RHOHV":
            v[~((v > _RHOHV_LIMITS[0]) & (v <= _RHOHV_LIMITS[1]))] = np.nan
        elif name == "PHIDP":
            v[~np.isfinite(v)] = np.nan
            v = _wrap360(v)
        elif name == "WRADH":
            # Width shares velocity's code table, so codes below 129 decode to negatives.
            v[~(v >= 0.0)] = np.nan
        else:
            v[~np.isfinite(v)] = np.nan
        out[name] = v
    if "DBZH" in out:
        # Without an echo there is nothing the other moments could have measured.
        no_echo = np.isnan(out["DBZH"])
        for name, v in out.items():
            if name != "DBZH":
                v[no_echo] = np.nan
    return out


# ------------------------------------------------------------------ geometry helpers


def _wrap360(angle: np.ndarray) -> np.ndarray:
    """Wrap angles into [0, 360) in their own dtype (NaN stays NaN); returns a new array."""
    wrapped = np.array(angle, copy=True)
    # Only the angles outside the turn: np.mod is slow on the NaN of a masked field, and
    # leaves an angle already in [0, 360) unchanged anyway.
    outside = (wrapped < 0.0) | (wrapped >= 360.0)
    folded = np.mod(wrapped[outside], wrapped.dtype.type(360.0))
    # mod of a tiny negative number rounds to exactly 360 in floating point.
    folded[folded >= 360.0] = 0.0
    wrapped[outside] = folded
    return wrapped


def _check_sector(
    sector_deg: tuple[float, float] | None, margin_deg: float
) -> tuple[tuple[float, float] | None, float]:
    """Validate the sector arguments early, before any file is read."""
    margin = float(margin_deg)
    if not np.isfinite(margin) or margin < 0:
        raise ValueError(f"margin_deg must be a finite, non-negative angle, got {margin_deg}")
    if sector_deg is None:
        return None, margin
    if len(sector_deg) != 2:
        raise ValueError(f"sector_deg must be (az0, az1), got {sector_deg!r}")
    az0, az1 = (float(a) for a in sector_deg)
    if not (np.isfinite(az0) and np.isfinite(az1)):
        raise ValueError(f"sector_deg must be finite angles, got {sector_deg!r}")
    return (az0, az1), margin


def _sector_order(
    azimuth: np.ndarray, sector_deg: tuple[float, float] | None, margin_deg: float
) -> np.ndarray:
    """Indices of the radials inside the sector, in clockwise order from its start."""
    if sector_deg is None:
        start, span = 0.0, 360.0
    else:
        az0, az1 = sector_deg
        if az1 - az0 >= 360.0:
            start, span = az0, 360.0
        else:
            span = (az1 - az0) % 360.0 + 2.0 * margin_deg
            start = az0 - margin_deg if span < 360.0 else az0
    offset = np.mod(azimuth - start, 360.0)
    # Tolerance for sector edges given as decimal angles that are not exact binary floats.
    inside = np.flatnonzero(offset <= span + 1e-9) if span < 360.0 else np.arange(azimuth.size)
    return inside[np.argsort(offset[inside], kind="stable")]


def _drop_duplicate_radials(azimuth: np.ndarray, radial_width_deg: float) -> np.ndarray:
    """Indices of radials to keep when a sweep overlaps itself (e.g. 721 radials).

    Of two radials closer than half a radial spacing, the later one (higher index, as rows
    come in time order) is dropped, so the truth grid never holds a radial twice.
    """
    n = azimuth.size
    if n < 2 or not np.isfinite(radial_width_deg):
        return np.arange(n)
    by_az = np.argsort(azimuth, kind="stable")
    gap = np.mod(np.diff(azimuth[np.append(by_az, by_az[0])]), 360.0)
    close = np.flatnonzero(gap < 0.5 * radial_width_deg)
    if close.size == 0:
        return np.arange(n)
    pairs = np.stack([by_az[close], by_az[(close + 1) % n]])
    keep = np.ones(n, dtype=bool)
    keep[pairs.max(axis=0)] = False
    return np.flatnonzero(keep)


def _nearest_circular(target: np.ndarray, source: np.ndarray, tolerance: float) -> np.ndarray:
    """For each target azimuth, the index of the nearest source azimuth, or -1 if too far.

    Of source radials at exactly the same azimuth (a sweep that overlaps itself) the one
    with the lowest index, i.e. the earlier in time, is taken.
    """
    if source.size == 0:
        return np.full(target.size, -1, dtype=np.intp)
    order = np.argsort(source, kind="stable")
    ring = source[order]
    # Pad the sorted ring with its neighbours across north so the search never falls off.
    padded = np.concatenate([ring[-1:] - 360.0, ring, ring[:1] + 360.0])
    pos = np.clip(np.searchsorted(padded, target), 1, padded.size - 1)
    left, right = padded[pos - 1], padded[pos]
    pick = np.where(target - left <= right - target, pos - 1, pos)
    # First of a run of equal azimuths: the stable sort put the earliest radial there.
    pick = np.searchsorted(padded, padded[pick], side="left")
    dist = np.abs(padded[pick] - target)
    index = order[(pick - 1) % ring.size]
    return np.where(dist <= tolerance, index, -1)


def _nominal_spacing(azimuth: np.ndarray) -> float:
    """Nominal radial spacing when the headers do not give it: 0.5 or 1 deg if close."""
    if azimuth.size < 2:
        return float("nan")
    ring = np.sort(_wrap360(azimuth.astype(np.float64)))
    median = float(np.median(np.diff(ring)))
    for nominal in (0.5, 1.0):
        if abs(median - nominal) <= 0.1 * nominal:
            return nominal
    return median


def _gate_width(range_m: np.ndarray) -> float:
    """Gate spacing, robust to float32 rounding of the range coordinate."""
    if range_m.size < 2:
        return float("nan")
    return float(np.round(np.median(np.diff(range_m)), 3))
