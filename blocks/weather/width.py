"""Spectrum width as the simulated radar would see it.

A radar file's width is that radar's own measurement. Doviak and Zrnic (1993, section 5.3)
write the measured width as a sum in quadrature, sigma^2 = sigma_t^2 (turbulence) + sigma_s^2
(shear across the beam) + sigma_d^2 (fall speeds, negligible at low elevation) +
sigma_alpha^2 (antenna rotation), with sigma_alpha = alpha lambda sqrt(ln 2) / (2 pi theta_1)
for a dish turning at alpha rad/s with one-way 3-dB beamwidth theta_1 (their eq. 5.38).

The weather channel (``width_model: physical``) therefore:

1. takes a truth measured by a radar (every truth but the synthetic scenes, whose widths are
   intrinsic by construction) as that radar's measurement, and removes its rotation
   broadening in quadrature. The truth carries no scan rate, so it is a parameter; its default
   is the bundled KLBB volume's: the 0.5 deg Doppler cut turns 360 deg in 31.7 s, 11.4 deg/s
   (measured on its radial time stamps), with the WSR-88D's one-way beamwidth (0.95 deg) and
   S-band wavelength (10.7 cm): sigma_alpha = 0.170 m/s. For another radar's file, set the
   three to that radar's;
2. gives gates reported below ``truth_width_floor_ms`` that width before the subtraction:
   Level-II widths come in 0.5 m/s steps, so a reported 0 says the measured width was under
   0.25 m/s, and a measured width is never below the radar's own rotation broadening. The
   floor is the largest width the report allows, 0.25 m/s (an intrinsic 0.18 m/s), instead
   of a pure tone, whose power never averages down however many pulses are taken;
3. adds the simulated radar's own scan modulation, from the scan's rate and the beamwidth
   measured on the pattern, for a rotating antenna; none for a beam stepped electronically
   (it stands still during its dwell).

The simulated radar's shear across its beam is not added here: the channel sums the truth
cells under the beam with their own velocities through the two-way pattern, which is that
shear at the truth's resolution. The truth radar's own shear broadening (across its 1-deg
beam, below the truth's 0.5-deg radial spacing) stays in the intrinsic width: estimating it
from the truth's quantised and noisy velocities would remove their noise as well.

``width_model: truth`` uses the truth's widths as given (zeros drawn as pure tones), as the
channel did before.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from pasim_graph import Param

from ..signals import SPEED_OF_LIGHT
from .clutter import ROTATING, one_way_beamwidth, scan_modulation_width

#: Width models of the weather channel.
WIDTH_MODELS = ("physical", "truth")
#: Carrier frequency of the truth's radar (WSR-88D, S band: 10.71 cm).
TRUTH_FREQUENCY_HZ = 2.8e9
#: Defaults of the truth radar's rotation: KLBB 2016-06-01 15:00, 0.5 deg Doppler cut.
TRUTH_SCAN_RATE_DEG_S = 11.4
TRUTH_BEAMWIDTH_DEG = 0.95
#: Half the Level-II width step: a reported 0 is a measured width under this.
TRUTH_WIDTH_FLOOR_MS = 0.25


@dataclass(frozen=True)
class WidthModel:
    """How truth widths become this radar's (:func:`radar_widths`): the model and the radar
    that measured the truth (see :class:`WidthParams` for each)."""

    model: str = "physical"
    truth_scan_rate_deg_s: float = TRUTH_SCAN_RATE_DEG_S
    truth_beamwidth_deg: float = TRUTH_BEAMWIDTH_DEG
    truth_frequency_hz: float = TRUTH_FREQUENCY_HZ
    truth_width_floor_ms: float = TRUTH_WIDTH_FLOOR_MS


class WidthParams:
    """The weather channel's width parameters, as a mixin: a Block subclass inherits them."""

    p: dict  # the block's parameters (Block)

    width_model = Param(
        "physical",
        type="str",
        choices=WIDTH_MODELS,
        doc="spectrum widths: physical (the truth radar's rotation broadening removed, a floor "
        "for widths it reports as 0, this radar's scan modulation added; see "
        "pasim_blocks.weather.width) or truth (as given; width 0 is a pure tone)",
    )
    truth_scan_rate_deg_s = Param(
        TRUTH_SCAN_RATE_DEG_S,
        units="deg/s",
        min=0.0,
        max=100.0,
        doc="azimuth rate of the radar that measured the truth (KLBB's 0.5 deg Doppler cut)",
    )
    truth_beamwidth_deg = Param(
        TRUTH_BEAMWIDTH_DEG,
        units="deg",
        min=0.1,
        max=10.0,
        doc="one-way 3-dB beamwidth of the radar that measured the truth (WSR-88D)",
    )
    truth_frequency_hz = Param(
        TRUTH_FREQUENCY_HZ,
        units="Hz",
        min=1e8,
        max=1e11,
        doc="carrier frequency of the radar that measured the truth (WSR-88D: S band)",
    )
    truth_width_floor_ms = Param(
        TRUTH_WIDTH_FLOOR_MS,
        units="m/s",
        min=0.0,
        max=5.0,
        doc="measured width given to truth gates reported below it (Level-II 0: under half "
        "its 0.5 m/s step)",
    )
    antenna_motion = Param(
        "auto",
        type="str",
        choices=("auto", "rotating", "electronic"),
        doc="rotating antenna (scan modulation widens the spectrum) or electronically stepped "
        "beam (none); auto: from the pattern's antenna",
    )

    def widths(self) -> WidthModel:
        """The block's width parameters, as :func:`radar_widths` takes them."""
        return WidthModel(
            str(self.p["width_model"]),
            float(self.p["truth_scan_rate_deg_s"]),
            float(self.p["truth_beamwidth_deg"]),
            float(self.p["truth_frequency_hz"]),
            float(self.p["truth_width_floor_ms"]),
        )


def measured_by_radar(truth: xr.Dataset) -> bool:
    """True for a truth read from a radar's file (its widths are that radar's
    measurement); False for the synthetic scenes and truths that say nothing."""
    name = str(truth.attrs.get("instrument_name", "synthetic"))
    return name not in ("", "synthetic")


def intrinsic_width(
    width_ms: np.ndarray,
    rate_deg_s: float,
    beamwidth_deg: float,
    wavelength_m: float,
    floor_ms: float,
) -> np.ndarray:
    """The truth radar's measured widths with its rotation broadening removed in quadrature,
    widths under ``floor_ms`` raised to it first (NaN stays NaN)."""
    sigma = scan_modulation_width(rate_deg_s, wavelength_m, beamwidth_deg)
    measured = np.where(np.isnan(width_ms), np.nan, np.maximum(width_ms, floor_ms))
    return np.sqrt(np.maximum(measured**2 - sigma**2, 0.0))


def antenna_rotates(pattern: xr.Dataset, motion: str) -> bool:
    """Whether the beam moves with a dish during a dwell (``motion`` auto: from the pattern's
    antenna, as :class:`~pasim_blocks.weather.clutter.GroundClutter` decides)."""
    if motion == "auto":
        return str(pattern.attrs.get("antenna", "")) in ROTATING
    return motion == "rotating"


def scan_broadening(
    beams: xr.Dataset, pattern: xr.Dataset, wavelength_m: float, motion: str
) -> np.ndarray:
    """Each beam's scan modulation (m/s): alpha lambda sqrt(ln 2) / (2 pi theta_1) with the
    beam's own azimuth rate and theta_1 measured on its own H pattern; 0 for an
    electronically stepped beam or a scan without a rate. Per beam, so that a beam's draw does
    not depend on which chunk it falls in. Rounded to 1e-4 m/s, so that beams which differ
    only by rounding share their prepared cells."""
    n = beams.sizes["beam"]
    if not antenna_rotates(pattern, motion) or "scan_rate" not in beams:
        return np.zeros(n)
    rates = np.abs(np.broadcast_to(beams["scan_rate"].values, (n,)))
    d_az = pattern["azimuth_offset_deg"].values
    d_el = pattern["elevation_offset_deg"].values
    power = pattern["power"].values
    out = np.empty(n)
    for i in range(n):
        theta = one_way_beamwidth(power[i, 0], d_az, d_el)
        out[i] = scan_modulation_width(float(rates[i]), wavelength_m, theta)
    return np.round(out, 4)


def radar_widths(truth: xr.Dataset, widths: WidthModel, broadening_ms: float) -> xr.Dataset:
    """The truth with WRADH as the simulated radar sees it (model ``physical``), or the truth
    itself (``truth``, or no WRADH)."""
    if widths.model == "truth" or "WRADH" not in truth:
        return truth
    width = truth["WRADH"].values.astype(np.float64)
    if measured_by_radar(truth):
        width = intrinsic_width(
            width,
            widths.truth_scan_rate_deg_s,
            widths.truth_beamwidth_deg,
            SPEED_OF_LIGHT / widths.truth_frequency_hz,
            widths.truth_width_floor_ms,
        )
    if broadening_ms > 0:
        width = np.hypot(width, broadening_ms)
    out = truth.copy()
    out["WRADH"] = (truth["WRADH"].dims, width.astype(np.float32), truth["WRADH"].attrs)
    return out
