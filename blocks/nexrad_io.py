"""Read one elevation of a NEXRAD Level-II volume as a cleaned "truth" sweep.

The simulator needs, for one elevation angle, every moment the WSR-88D measured on a
common polar grid: reflectivity and the dual-polarisation moments from the surveillance
(long PRT) cut, radial velocity and spectrum width from the Doppler (short PRT) cut that
follows it at the same elevation. :func:`read_truth_sweep` finds those cuts, reads only
them with xradar, masks the Level-II "no data" codes, merges the two cuts by azimuth and
range, and cleans values outside their physical range.

Notes
-----
xradar 0.12 decodes the Level-II codes 0 (below threshold) and 1 (range folded) as
ordinary numbers (for example -33 dBZ, -8 dB, 0.2017, -0.705 deg, -64.5 m/s). This module
therefore reads the undecoded codes (``mask_and_scale=False``), masks codes 0 and 1
exactly, and applies each moment's scale and offset itself; no float comparison against
sentinel values is involved.
"""

from __future__ import annotations

import bz2
import gzip
import struct
import warnings
import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
import xradar
from xradar.io.backends.nexrad_level2 import NEXRADLevel2File

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

# Level-II data block names as they appear in message 31 / message 1 headers.
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

# Requests farther than this from every cut are almost certainly a wrong file or a typo.
_MAX_ELEVATION_MISMATCH_DEG = 1.0
# Split cuts repeat the VCP angle exactly; distinct VCP elevations are >= 0.4 deg apart.
_SAME_ELEVATION_DEG = 0.1

# Physical limits beyond which a decoded value is garbage rather than a measurement.
_DBZH_LIMITS = (-35.0, 100.0)
_ZDR_LIMITS = (-8.0, 8.0)
_RHOHV_LIMITS = (0.0, 1.1)  # open below, closed above: rho > 1 is a real estimate

# Level-II archives start with "AR2V00nn." (build 10+) or "ARCHIVE2." (older builds).
_VOLUME_MAGIC = (b"AR2V", b"ARCHIVE2")
_VOLUME_HEADER_BYTES = 24
_CTM_BYTES = 12


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
        float64, shape (gate,). Range to the gate centres of the surveillance cut.
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
        ``time_coverage_start`` (ISO string).
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
class _Cut:
    """What the message headers say about one sweep of the volume, before reading data."""

    index: int  # sweep number in the file, as xradar's ``sweep=`` expects
    fixed_angle: float
    elevation_number: int
    moments: frozenset[str]
    nyquist_velocity_ms: float
    radial_width_deg: float  # NaN when the headers do not say
    complete: bool = True  # False when the file ends inside this sweep

    @property
    def has_polarimetry(self) -> bool:
        return any(name in self.moments for name in POLARIMETRIC_FIELDS)

    @property
    def has_doppler(self) -> bool:
        return "VRADH" in self.moments


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
        Level-II (Archive II) volume; bzip2-compressed records, uncompressed records and a
        whole-file gzip or bzip2 wrapper are all accepted.
    elevation_deg : float, optional
        Wanted elevation; the cuts whose VCP fixed angle is nearest are used.
    sector_deg : tuple of float, optional
        ``(az0, az1)``: keep radials from ``az0`` clockwise to ``az1`` (degrees; wrapping
        through north is allowed, ``(0, 360)`` is the full circle). None keeps all radials.
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
    Split cuts are merged: DBZH/ZDR/RHOHV/PHIDP come from the surveillance cut, VRADH/WRADH
    from the Doppler cut at the same elevation, matched to each surveillance radial by the
    nearest azimuth within half a radial spacing and to each gate by range; beyond the
    Doppler cut's shorter range they are NaN. A cut that carries all moments is used alone.

    Cleaning: Level-II codes 0 and 1 -> NaN; DBZH outside [-35, 100] dBZ, ZDR outside
    [-8, 8] dB, RHOHV outside (0, 1.1] and negative WRADH -> NaN; PHIDP wrapped into
    [0, 360); RHOHV above 1 and folded VRADH are kept as measured. Wherever DBZH is NaN
    every other moment is NaN too.
    """
    path = Path(path)
    sector, margin = _check_sector(sector_deg, margin_deg)
    volume = _load_volume_bytes(path)
    cuts = _scan_cuts(volume, path)
    surveillance, doppler = _choose_cuts(cuts, float(elevation_deg), path)

    wanted = [surveillance.index] + ([doppler.index] if doppler is not None else [])
    for cut in (surveillance, doppler):
        if cut is not None and not cut.complete:
            # Real-time chunks and cut-off downloads end mid-sweep; the result is still usable
            # but has NaN (or interpolated-azimuth) radials the caller should know about.
            warnings.warn(
                f"{path}: sweep {cut.index} ({cut.fixed_angle:.2f} deg) is incomplete; "
                "radials missing from the file are NaN",
                UserWarning,
                stacklevel=2,
            )
    try:
        # The undecoded codes let us mask codes 0/1 exactly; xradar decodes them as data.
        tree = xradar.io.open_nexradlevel2_datatree(
            volume, sweep=wanted, first_dim="time", mask_and_scale=False
        )
        surv_ds = tree[f"sweep_{surveillance.index}"].to_dataset().load()
        dopp_ds = None
        if doppler is not None:
            dopp_ds = tree[f"sweep_{doppler.index}"].to_dataset().load()
        root = tree.to_dataset()
    except (struct.error, EOFError, KeyError, IndexError, OSError) as err:
        raise ValueError(f"{path}: could not decode sweeps {wanted} ({err!r})") from err

    radial_width = surveillance.radial_width_deg
    if not np.isfinite(radial_width):
        radial_width = _nominal_spacing(surv_ds["azimuth"].to_numpy())
    azimuth, range_m, fields = _assemble(
        surv_ds, dopp_ds, radial_width_deg=radial_width, sector_deg=sector, margin_deg=margin
    )
    if azimuth.size == 0:
        raise ValueError(
            f"{path}: no radial of the {surveillance.fixed_angle:.2f} deg cut lies in sector "
            f"{sector_deg} with margin {margin_deg} deg"
        )

    nyquist_cut = surveillance if doppler is None else doppler
    return TruthSweep(
        azimuth_deg=azimuth,
        elevation_deg=float(np.mean(surv_ds["elevation"].to_numpy())),
        range_m=range_m,
        radial_width_deg=float(radial_width),
        gate_width_m=_gate_width(range_m),
        fields=fields,
        nyquist_velocity_ms=nyquist_cut.nyquist_velocity_ms,
        site=_site(root),
        source=path.name,
    )


# ------------------------------------------------------------------------- file access


def _load_volume_bytes(path: Path) -> bytes:
    """Return the volume as uncompressed Level-II bytes, validating what it is.

    Decompressing the bzip2 records once here is not just convenience: xradar parses the
    message headers twice per open and decompresses every record each time, so handing it
    plain records halves the cost of the read.
    """
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
    if not raw.startswith(_VOLUME_MAGIC):
        raise ValueError(
            f"{path} is not a NEXRAD Level-II (Archive II) volume: expected a 24-byte volume "
            f"header starting with 'AR2V' or 'ARCHIVE2', found {raw[:8]!r}"
        )
    return _decompress_records(raw, path)


def _decompress_records(raw: bytes, path: Path) -> bytes:
    """Undo the per-record bzip2 compression of a Level-II volume, if it has any.

    Each compressed record is a 4-byte big-endian length (negative for the last record)
    followed by one bzip2 stream; the decompressed records simply follow each other.
    """
    first = _VOLUME_HEADER_BYTES
    if raw[first + 4 : first + 7] != b"BZh":
        return raw
    parts = [raw[:first]]
    pos = first
    while pos + 4 <= len(raw):
        size = abs(int.from_bytes(raw[pos : pos + 4], "big", signed=True))
        if size == 0:
            break
        try:
            # A decompressor object returns what it can of a record cut short by a
            # truncated download; xradar then reports the last sweep as incomplete.
            parts.append(bz2.BZ2Decompressor().decompress(raw[pos + 4 : pos + 4 + size]))
        except OSError as err:
            raise ValueError(f"{path}: corrupt bzip2 record at byte {pos} ({err})") from err
        pos += 4 + size
    volume = bytearray(b"".join(parts))
    # xradar tells compressed from plain files by bytes 24..27; in plain records those are
    # the first record's CTM header, which Archive II leaves unused, so zeroing it is safe.
    volume[first : first + _CTM_BYTES] = bytes(_CTM_BYTES)
    return bytes(volume)


def _scan_cuts(volume: bytes, path: Path) -> list[_Cut]:
    """Describe every sweep of the volume from its message headers alone."""
    try:
        with NEXRADLevel2File(volume, loaddata=False) as nex:
            msg_5 = nex.msg_5
            vcp_cuts = list(msg_5.get("elevation_data", [])) if msg_5 else []
            radial_headers = nex.msg_31_header
            block_headers = nex.msg_31_data_header
            incomplete = nex.incomplete_sweeps
            cuts = [
                _describe_cut(i, radial_headers[i], block_headers[i], vcp_cuts, i not in incomplete)
                for i in sorted(nex.data)
            ]
    except (struct.error, EOFError, KeyError, IndexError, OSError) as err:
        raise ValueError(f"{path}: could not decode the Level-II headers ({err!r})") from err
    if not cuts:
        raise ValueError(f"{path}: the Level-II volume holds no radial data")
    return cuts


def _describe_cut(
    index: int, radials: list[dict], blocks: dict, vcp_cuts: list[dict], complete: bool = True
) -> _Cut:
    """Summarise one sweep from its radial headers and first radial's data blocks."""
    legacy = blocks["msg_type"] == 1
    # Message 1 stores angles as 16-bit binary angles; message 31 stores degrees.
    angle_scale = 180.0 / 32768.0 if legacy else 1.0
    measured = float(np.median([r["elevation_angle"] for r in radials])) * angle_scale
    elevation_number = int(radials[0]["elevation_number"])

    fixed = measured
    if 1 <= elevation_number <= len(vcp_cuts):
        vcp_angle = float(vcp_cuts[elevation_number - 1]["elevation_angle"])
        # Message 5 can be garbage (e.g. maintenance VCPs); trust it only near the antenna.
        if abs(vcp_angle - measured) <= _MAX_ELEVATION_MISMATCH_DEG:
            fixed = vcp_angle

    data_blocks = blocks["msg_31_data_header"]
    moments = frozenset(_MOMENT_NAMES[k] for k in data_blocks if k in _MOMENT_NAMES)
    if legacy:
        nyquist_raw = radials[0].get("nyquist_vel", 0)
        radial_width = 1.0  # message 1 predates super-resolution
    else:
        nyquist_raw = data_blocks.get("RAD", {}).get("nyquist_vel", 0)
        radial_width = {1: 0.5, 2: 1.0}.get(int(radials[0].get("azimuth_resolution", 0)), np.nan)
    # Both messages store the Nyquist velocity in 0.01 m/s; 0 means not recorded.
    nyquist = nyquist_raw / 100.0 if nyquist_raw else np.nan
    return _Cut(
        index, fixed, elevation_number, moments, float(nyquist), float(radial_width), complete
    )


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


# ---------------------------------------------------------------------- data assembly


def _assemble(
    surv_ds: xr.Dataset,
    dopp_ds: xr.Dataset | None,
    *,
    radial_width_deg: float,
    sector_deg: tuple[float, float] | None,
    margin_deg: float,
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Merge undecoded surveillance and Doppler sweeps into cleaned, sector-cut fields.

    Both datasets hold Level-II codes with ``scale_factor``/``add_offset`` attributes, one
    row per radial (any order) and ``azimuth``/``range`` coordinates.
    """
    azimuth = _wrap360(surv_ds["azimuth"].to_numpy().astype(np.float64))
    keep = _drop_duplicate_radials(azimuth, radial_width_deg)
    order = keep[_sector_order(azimuth[keep], sector_deg, margin_deg)]
    azimuth = azimuth[order]
    range_m = surv_ds["range"].to_numpy().astype(np.float64)

    fields: dict[str, np.ndarray] = {}
    for name in SURVEILLANCE_FIELDS:
        if name in surv_ds:
            fields[name] = _decode(surv_ds[name])[order]
    for name in DOPPLER_FIELDS:
        if dopp_ds is None:
            if name in surv_ds:  # a cut that measured everything at once
                fields[name] = _decode(surv_ds[name])[order]
        elif name in dopp_ds:
            fields[name] = _regrid(dopp_ds, name, azimuth, range_m, radial_width_deg)
    return azimuth, range_m, _clean(fields)


def _decode(var: xr.DataArray) -> np.ndarray:
    """Turn Level-II codes into float32 physical values, NaN for codes 0 and 1."""
    codes = var.to_numpy()
    try:
        scale = float(var.attrs["scale_factor"])
        offset = float(var.attrs["add_offset"])
    except KeyError as err:
        raise ValueError(f"moment {var.name} lacks its scale/offset; read it undecoded") from err
    values = codes.astype(np.float64) * scale + offset
    return np.where(codes >= _FIRST_DATA_CODE, values, np.nan).astype(np.float32)


def _regrid(
    source: xr.Dataset,
    name: str,
    azimuth: np.ndarray,
    range_m: np.ndarray,
    radial_width_deg: float,
) -> np.ndarray:
    """Sample a Doppler-cut moment onto the surveillance radials and gates."""
    src_az = _wrap360(source["azimuth"].to_numpy().astype(np.float64))
    src_rng = source["range"].to_numpy().astype(np.float64)
    rows = _nearest_circular(azimuth, src_az, 0.5 * radial_width_deg)
    gate_tol = 0.5 * max(_gate_width(range_m), _gate_width(src_rng))
    cols = _nearest_sorted(range_m, src_rng, gate_tol)
    values = _decode(source[name])
    out = np.full((azimuth.size, range_m.size), np.nan, dtype=np.float32)
    ok_r, ok_c = rows >= 0, cols >= 0
    out[np.ix_(ok_r, ok_c)] = values[np.ix_(rows[ok_r], cols[ok_c])]
    return out


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
    """Wrap angles into [0, 360) in their own dtype."""
    wrapped = np.mod(angle, angle.dtype.type(360.0))
    # mod of a tiny negative number rounds to exactly 360 in floating point.
    wrapped[wrapped >= 360.0] = 0.0
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
    """For each target azimuth, the index of the nearest source azimuth, or -1 if too far."""
    if source.size == 0:
        return np.full(target.size, -1, dtype=np.intp)
    order = np.argsort(source)
    ring = source[order]
    # Pad the sorted ring with its neighbours across north so the search never falls off.
    padded = np.concatenate([ring[-1:] - 360.0, ring, ring[:1] + 360.0])
    pos = np.clip(np.searchsorted(padded, target), 1, padded.size - 1)
    left, right = padded[pos - 1], padded[pos]
    pick = np.where(target - left <= right - target, pos - 1, pos)
    dist = np.abs(padded[pick] - target)
    index = order[(pick - 1) % ring.size]
    return np.where(dist <= tolerance, index, -1)


def _nearest_sorted(target: np.ndarray, source: np.ndarray, tolerance: float) -> np.ndarray:
    """For each target range, the index of the nearest (sorted) source range, or -1."""
    if source.size == 0:
        return np.full(target.size, -1, dtype=np.intp)
    pos = np.clip(np.searchsorted(source, target), 1, max(source.size - 1, 1))
    if source.size == 1:
        pick = np.zeros(target.size, dtype=np.intp)
    else:
        left, right = source[pos - 1], source[pos]
        pick = np.where(target - left <= right - target, pos - 1, pos)
    return np.where(np.abs(source[pick] - target) <= tolerance, pick, -1)


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


def _site(root: xr.Dataset) -> dict[str, Any]:
    """Radar site and volume time from the root group of an xradar tree."""

    def number(name: str) -> float:
        return float(root[name].to_numpy()) if name in root else float("nan")

    start = root["time_coverage_start"].to_numpy() if "time_coverage_start" in root else ""
    return {
        "latitude": number("latitude"),
        "longitude": number("longitude"),
        "altitude": number("altitude"),
        "instrument_name": str(root.attrs.get("instrument_name", "")),
        "time_coverage_start": str(start),
    }
