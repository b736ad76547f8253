"""Antennas: one-way H and V patterns around each beam's axis.

A pattern is sampled on a grid of azimuth and elevation offsets from the beam axis and
normalised to the antenna's peak gain (``gain_db`` attribute), so that scan loss and H/V
mismatch off broadside show as values below 1 and as P_H != P_V. The weather channel squares
``power`` (the same antenna transmits and receives) and integrates it over each truth cell.
Array antennas also give the complex co- and cross-polar voltage patterns of both ports
(``co_polar``, ``cross_polar``), from which the two-way coupling of SHV and AHV transmission
follows (``pasim_blocks.weather.polarimetry``, docs/arrays.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Param

from ..signals import POLARIZATIONS

#: Parameters several antennas declare alike (each class gets its own named copy).
PATTERN_SUPPORT = Param(
    10.0, units="deg", min=0.5, max=45.0, doc="half-width of the pattern grid around the beam axis"
)
PATCH_SIDE = Param(
    0.0524, units="m", min=1e-3, max=1.0, doc="side of the square patch (paper Table 1)"
)

# ---- parameters shared by the array antennas ---------------------------------------------------

ELEMENT = Param(
    "patch",
    type="str",
    choices=("patch", "crossed_dipole", "isotropic", "file"),
    doc="radiating element: cavity-model patch, crossed dipoles, isotropic, or element_file",
)
ELEMENT_FILE = Param(
    "",
    type="path",
    doc="element pattern file (element 'file'; format in docs/arrays.md)",
)
CROSS_POL = Param(
    None,
    units="dB",
    min=-100.0,
    max=0.0,
    optional=True,
    doc="intrinsic leakage: each port also radiates the other's field this far below (unset: none)",
)
CROSS_POL_PHASE = Param(
    0.0, units="deg", min=-180.0, max=180.0, doc="phase of the intrinsic cross-polar leakage"
)
TAPER = Param(
    "taylor", type="str", choices=("taylor", "kaiser", "uniform"), doc="amplitude taper family"
)
KAISER_BETA = Param(4.0, min=0.0, max=20.0, doc="Kaiser taper beta (taper 'kaiser')")
AMPLITUDE_ERROR = Param(
    0.0, units="dB", min=0.0, max=10.0, doc="channel-to-channel amplitude error, rms"
)
PHASE_ERROR = Param(0.0, units="deg", min=0.0, max=180.0, doc="channel-to-channel phase error, rms")
FAILURES = Param(0.0, min=0.0, max=0.99, doc="probability that a T/R module has failed")
PHASE_BITS = Param(
    0, type="int", min=0, max=16, doc="phase shifter bits (0: continuous, ideal phase shifters)"
)
ATTENUATOR_BITS = Param(
    0, type="int", min=0, max=16, doc="attenuator bits for the taper (0: continuous)"
)
ATTENUATOR_LSB = Param(0.5, units="dB", min=0.01, max=10.0, doc="attenuator step")
RANDOMIZE = Param(
    False,
    type="bool",
    doc="randomise the quantisation (known random insertion phases): no quantisation lobes",
)
ERRORS_SEED = Param(
    None,
    type="int",
    min=0,
    optional=True,
    doc="seed of the channel errors (unset: drawn from the run seed)",
)
CALIBRATION = Param(
    "per_beam",
    type="str",
    choices=("per_beam", "boresight"),
    doc="radar constant per beam from its own two-way pattern, or the broadside one for all",
)


def steering(beams: xr.Dataset) -> tuple[np.ndarray, np.ndarray]:
    """Where an array steers each beam, in its own frame: the beams' ``array_azimuth`` and
    ``array_elevation`` on a platform (the face then turns with the platform, and the pattern
    is carried to the beam's earth direction by the weather channel), else their azimuth and
    elevation (a still radar: one frame)."""
    if "array_azimuth" in beams:
        return beams["array_azimuth"].values, beams["array_elevation"].values
    return beams["azimuth"].values, beams["elevation"].values


def offsets(support_deg: float, step_deg: float) -> np.ndarray:
    n = int(np.ceil(support_deg / step_deg))
    return np.arange(-n, n + 1) * step_deg


def two_way_solid_angle(
    power: np.ndarray, d_az: np.ndarray, d_el: np.ndarray, elevation_deg: float
) -> float:
    """Integral of the two-way power pattern over the grid, in steradians."""
    step = np.deg2rad(d_az[1] - d_az[0]) * np.deg2rad(d_el[1] - d_el[0])
    cos_el = np.cos(np.deg2rad(elevation_deg + d_el))[:, None]
    return float(np.sum(power.astype(np.float64) ** 2 * cos_el) * step)


def pattern_dataset(
    power: np.ndarray,
    d_az: np.ndarray,
    d_el: np.ndarray,
    gain_db: float,
    solid_angle_sr: dict[str, float],
    *,
    calibration_sr: np.ndarray | None = None,
    co_polar: np.ndarray | None = None,
    cross_polar: np.ndarray | None = None,
    **attrs: Any,
) -> xr.Dataset:
    """The pattern port's Dataset.

    ``solid_angle_sr`` holds the boresight (broadside) two-way solid angles; ``calibration_sr``
    (beam x polarisation) the per-beam ones, when the antenna calibrates per beam (otherwise
    every beam gets the boresight value).
    """
    dims = ("beam", "polarization", "elevation_offset", "azimuth_offset")
    boresight = np.tile([solid_angle_sr[p] for p in POLARIZATIONS], (power.shape[0], 1))
    variables: dict[str, Any] = {
        "power": (dims, power, {"units": "1"}),
        "calibration_solid_angle_sr": (
            ("beam", "polarization"),
            boresight if calibration_sr is None else np.asarray(calibration_sr, np.float64),
            {"units": "sr"},
        ),
    }
    if co_polar is not None:
        variables["co_polar"] = (dims, co_polar.astype(np.complex64), {"units": "1"})
    if cross_polar is not None:
        variables["cross_polar"] = (dims, cross_polar.astype(np.complex64), {"units": "1"})
    return xr.Dataset(
        variables,
        coords={
            "polarization": list(POLARIZATIONS),
            "azimuth_offset_deg": ("azimuth_offset", d_az, {"units": "degrees"}),
            "elevation_offset_deg": ("elevation_offset", d_el, {"units": "degrees"}),
        },
        attrs={
            "gain_db": gain_db,
            "calibration": "boresight" if calibration_sr is None else "per_beam",
            **{f"two_way_solid_angle_sr_{p}": v for p, v in solid_angle_sr.items()},
            **attrs,
        },
    )
