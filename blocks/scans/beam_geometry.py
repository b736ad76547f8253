"""The beams Dataset every scan emits (FM-301 sweep variables along ``beam``), and what a scan
reads from the truth (start time, site)."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph.fm301 import (
    FOLLOW_MODE_NONE,
    INSTRUMENT_RADAR,
    PLATFORM_FIXED,
    PRT_ATTRS,
    PRT_MODE_FIXED,
    PULSES_ATTRS,
    SITE_VARIABLES,
    TIME_ATTRS,
    CFAttributes,
)

#: The start of a scan without a truth to take it from.
EPOCH = np.datetime64("2000-01-01T00:00:00", "ns")


def truth_context(truth: xr.Dataset | None) -> tuple[np.datetime64, dict[str, float]]:
    """The scan's start (the truth's ``time_coverage_start``) and the site's position."""
    site = dict.fromkeys(SITE_VARIABLES, 0.0)
    if truth is None:
        return EPOCH, site
    start = np.datetime64(str(truth.attrs.get("time_coverage_start", EPOCH)).rstrip("Z"), "ns")
    return start, {k: float(truth.attrs.get(k, 0.0)) for k in site}


def seconds(t: float) -> np.timedelta64:
    return np.timedelta64(round(t * 1e9), "ns")


def iso(t: np.datetime64) -> str:
    return str(np.datetime_as_string(t, unit="s")) + "Z"


def beam_dataset(
    cf: CFAttributes,
    *,
    azimuth: np.ndarray,
    elevation: np.ndarray,
    time: np.ndarray,
    prt: np.ndarray,
    pulses: int,
    scan_rate: np.ndarray | None,
    sweep_mode: str,
    fixed_angle: float,
    start: np.datetime64,
    end: np.datetime64,
    site: dict[str, float],
    rate_name: str = "azimuth rate of the scan",
    prt_mode: str = PRT_MODE_FIXED,
) -> xr.Dataset:
    """The beams of one chunk: per-beam pointing, dwell start, PRT and scan rate, the sweep's
    FM-301 variables (``prt_mode`` "fixed", "staggered" or "dual"; ``follow_mode`` "none": a
    ground radar follows no target), and the volume metadata the store moves to the root."""
    ds = xr.Dataset(
        {
            "sweep_number": ((), 0),
            "sweep_mode": ((), sweep_mode),
            "sweep_fixed_angle": ((), float(fixed_angle), dict(cf.elevation)),
            "prt_mode": ((), prt_mode),
            "follow_mode": ((), FOLLOW_MODE_NONE),
            "prt": ("beam", np.asarray(prt, np.float64), dict(PRT_ATTRS)),
            "pulses": ((), int(pulses), dict(PULSES_ATTRS)),
            # Volume metadata FM-301 asks for at the root (the store moves it there).
            "time_coverage_start": ((), iso(start)),
            "time_coverage_end": ((), iso(end)),
            "volume_number": ((), 0),
            "platform_type": ((), PLATFORM_FIXED),
            "instrument_type": ((), INSTRUMENT_RADAR),
        },
        coords={
            "azimuth": ("beam", np.asarray(azimuth, np.float64), dict(cf.azimuth)),
            "elevation": ("beam", np.asarray(elevation, np.float64), dict(cf.elevation)),
            "time": ("beam", time, dict(TIME_ATTRS)),
            **{k: ((), v) for k, v in site.items()},
        },
    )
    if scan_rate is not None:  # an electronically steered beam list does not move
        ds["scan_rate"] = (
            "beam",
            np.asarray(scan_rate, np.float64),
            {"units": "degrees/s", "long_name": rate_name},
        )
    ds["latitude"].attrs = dict(cf.latitude)
    ds["longitude"].attrs = dict(cf.longitude)
    ds["altitude"].attrs = dict(cf.altitude)
    return ds


def site_and_start(inputs: dict[str, Any], offset_s: float) -> tuple[np.datetime64, dict]:
    """The sweep's start (the truth's start plus ``offset_s``) and the site."""
    start, site = truth_context(inputs.get("truth"))
    return start + seconds(offset_s), site


#: Earth's mean radius (m) and the effective-radius factor of standard refraction.
EARTH_RADIUS_M = 6371000.0
FOUR_THIRDS = 4.0 / 3.0


def beam_height_m(range_m: np.ndarray, elevation_deg: np.ndarray) -> np.ndarray:
    """Height of the beam centre above the radar (m) under standard refraction: the 4/3-earth
    model (Doviak and Zrnic 1993, eq. 2.28b), h = sqrt(r^2 + (k a)^2 + 2 r k a sin(el)) - k a.
    """
    ka = FOUR_THIRDS * EARTH_RADIUS_M
    r = np.asarray(range_m, dtype=np.float64)
    sin = np.sin(np.deg2rad(np.asarray(elevation_deg, dtype=np.float64)))
    return np.sqrt(r**2 + ka**2 + 2.0 * r * ka * sin) - ka


def ground_range_m(range_m: np.ndarray, elevation_deg: np.ndarray) -> np.ndarray:
    """Distance along the ground to below the beam centre (m), 4/3-earth model (Doviak and
    Zrnic 1993, eq. 2.28c): s = k a asin(r cos(el) / (k a + h))."""
    ka = FOUR_THIRDS * EARTH_RADIUS_M
    r = np.asarray(range_m, dtype=np.float64)
    cos = np.cos(np.deg2rad(np.asarray(elevation_deg, dtype=np.float64)))
    return ka * np.arcsin(r * cos / (ka + beam_height_m(r, elevation_deg)))
