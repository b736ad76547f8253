"""Read one elevation of a NEXRAD Level-II volume as a cleaned "truth" sweep.

The simulator needs, for one elevation angle, every moment the WSR-88D measured on a
common polar grid: reflectivity and the dual-polarisation moments from the surveillance
(long PRT) cut, radial velocity and spectrum width from the Doppler (short PRT) cut that
follows it at the same elevation. :func:`read_truth_sweep` finds those cuts, decodes only
them (and, with a sector, only its radials), masks the Level-II "no data" codes, merges the
two cuts by azimuth and by range, and cleans values outside their physical range.

Notes
-----
This module and :mod:`pasim_blocks.truth.level2` decode the Level-II messages themselves
(ICD 2620010 for message 31, 2620002 for the legacy message 1), for three reasons:

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

import struct
import warnings
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from .gridding import assemble, check_sector, gate_width, nominal_spacing
from .level2 import (
    DOPPLER_FIELDS,
    FIELD_NAMES,
    POLARIMETRIC_FIELDS,
    SURVEILLANCE_FIELDS,
    DamagedRecord,
    choose_cuts,
    cut_data,
    scan_volume,
    site_attributes,
    time_order,
)

__all__ = [
    "DOPPLER_FIELDS",
    "FIELD_NAMES",
    "POLARIMETRIC_FIELDS",
    "SURVEILLANCE_FIELDS",
    "TruthSweep",
    "read_truth_sweep",
    "read_truth_sweeps",
    "volume_angles",
]


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
    unmapped : tuple of str
        The file's fields on the sweep's grid that no moment was taken from and that are no
        moment's alias (empty for Level-II): named in the note on a missing moment.
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
    unmapped: tuple[str, ...] = ()

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
    sector, margin = check_sector(sector_deg, margin_deg)
    volume = scan_volume(path, float(elevation_deg))
    return _sweep(path, volume, float(elevation_deg), sector, margin, sector_deg, margin_deg)


def volume_angles(path: str | PathLike[str]) -> list[float]:
    """The distinct fixed angles (deg, ascending) of a Level-II volume's cuts (headers only)."""
    volume = scan_volume(Path(path), 90.0)
    angles: list[float] = []
    for cut in sorted(volume.cuts, key=lambda c: c.fixed_angle):
        if "DBZH" in cut.moments and (not angles or cut.fixed_angle - angles[-1] > 0.1):
            angles.append(float(cut.fixed_angle))
    return angles


def read_truth_sweeps(
    path: str | PathLike[str],
    elevations_deg: list[float],
    sector_deg: tuple[float, float] | None = None,
    margin_deg: float = 0.0,
) -> list[TruthSweep]:
    """The truth sweeps at several elevations of one volume (each as :func:`read_truth_sweep`).

    The headers are read once, up to the end of the highest cut asked for; each elevation's
    cuts are then decoded (only the radials of the sector).
    """
    path = Path(path)
    sector, margin = check_sector(sector_deg, margin_deg)
    volume = scan_volume(path, float(max(elevations_deg)))
    return [
        _sweep(path, volume, float(e), sector, margin, sector_deg, margin_deg)
        for e in elevations_deg
    ]


def _sweep(
    path: Path,
    volume: Any,
    elevation_deg: float,
    sector: tuple[float, float] | None,
    margin: float,
    sector_deg: tuple[float, float] | None,
    margin_deg: float,
) -> TruthSweep:
    surveillance, doppler = choose_cuts(volume.cuts, elevation_deg, path)
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

    surv_radials = time_order(surveillance.radials)
    radial_width = surveillance.radial_width_deg
    if not np.isfinite(radial_width):
        radial_width = nominal_spacing(np.array([r.azimuth_deg for r in surv_radials]))
    nyquist_cut = surveillance if doppler is None else doppler
    try:
        azimuth, range_m, fields = assemble(
            cut_data(surv_radials),
            None if doppler is None else cut_data(time_order(doppler.radials)),
            radial_width_deg=radial_width,
            sector_deg=sector,
            margin_deg=margin,
            nyquist_velocity_ms=nyquist_cut.nyquist_velocity_ms,
        )
    except DamagedRecord as err:
        raise ValueError(f"{path}: a damaged record: {err}; refusing the file") from None
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
        gate_width_m=gate_width(range_m),
        fields=fields,
        nyquist_velocity_ms=nyquist_cut.nyquist_velocity_ms,
        site=site_attributes(volume.icao, surv_radials[0], used),
        source=path.name,
    )
