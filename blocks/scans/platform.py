"""The platform the array stands on: its velocity and acceleration, its attitude (heading,
pitch, roll, each with a constant rate) over the scan, and the rotation that carries a beam
steered in the array's frame to the earth's.

Frames: the array's (the platform's body) has x forward along the nose, y to the right, z
down; a beam steered at azimuth alpha (clockwise from the nose) and elevation epsilon (above
the deck) points along d_b = (cos e cos a, cos e sin a, -sin e). The platform's attitude turns
it to north-east-down by R = R_z(heading) R_y(pitch) R_x(roll) (the aerospace sequence: roll
positive right wing down, pitch positive nose up, heading clockwise from north), d_n = R d_b,
and the beam's azimuth and elevation on the earth are atan2(d_E, d_N) and asin(-d_D). With no
platform, or a still one with heading, pitch and roll 0, the two frames are the same.

The platform stands at the truth's site at the scan's start; its velocity at time t after the
start is v0 + a t (east, north, up), v0 the given components or, unset, the preset's speed
along the heading. Each beam is turned with the attitude at the middle of its dwell, and
carries the platform's velocity then (FM-301's ``heading``, ``pitch``, ``roll``,
``eastward_velocity``, ``northward_velocity``, ``vertical_velocity``) and its projection on the
beam, ``platform_radial_velocity`` (positive: the radar moves along the beam, toward what it
looks at), which the weather channel and the processor read.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Param
from pasim_graph.fm301 import PLATFORM_FIXED

#: Presets: CfRadial platform type and speed along the heading (m/s) when no velocity is given.
PRESETS = {
    "none": (PLATFORM_FIXED, 0.0),
    "ground": (PLATFORM_FIXED, 0.0),
    "ship": ("ship", 8.0),
    "airborne": ("aircraft", 150.0),
}


class PlatformParams:
    """The platform's parameters, as a mixin of a scan: a Block subclass inherits them."""

    platform = Param(
        "none",
        type="str",
        choices=tuple(PRESETS),
        doc="none (a still radar, beams in the earth frame), or a platform the beams are "
        "steered on: ground (still), ship (8 m/s), airborne (150 m/s) along the heading",
    )
    platform_heading_deg = Param(
        0.0, units="deg", min=-360.0, max=360.0, doc="heading at the scan's start (from north)"
    )
    platform_pitch_deg = Param(0.0, units="deg", min=-90.0, max=90.0, doc="pitch, nose up")
    platform_roll_deg = Param(0.0, units="deg", min=-180.0, max=180.0, doc="roll, right side down")
    platform_heading_rate_deg_s = Param(
        0.0, units="deg/s", min=-90.0, max=90.0, doc="constant rate of the heading"
    )
    platform_pitch_rate_deg_s = Param(
        0.0, units="deg/s", min=-90.0, max=90.0, doc="constant rate of the pitch"
    )
    platform_roll_rate_deg_s = Param(
        0.0, units="deg/s", min=-90.0, max=90.0, doc="constant rate of the roll"
    )
    platform_velocity_east_ms = Param(
        None,
        units="m/s",
        min=-1000.0,
        max=1000.0,
        optional=True,
        doc="velocity east at the start (unset, with north and up: the preset's speed along "
        "the heading)",
    )
    platform_velocity_north_ms = Param(
        None, units="m/s", min=-1000.0, max=1000.0, optional=True, doc="velocity north"
    )
    platform_velocity_up_ms = Param(
        None, units="m/s", min=-1000.0, max=1000.0, optional=True, doc="velocity up"
    )
    platform_acceleration_east_ms2 = Param(
        0.0, units="m/s2", min=-100.0, max=100.0, doc="acceleration east"
    )
    platform_acceleration_north_ms2 = Param(
        0.0, units="m/s2", min=-100.0, max=100.0, doc="acceleration north"
    )
    platform_acceleration_up_ms2 = Param(
        0.0, units="m/s2", min=-100.0, max=100.0, doc="acceleration up"
    )


def attitude_matrix(heading_deg: Any, pitch_deg: Any, roll_deg: Any) -> np.ndarray:
    """R = R_z(heading) R_y(pitch) R_x(roll), body (forward, right, down) to north-east-down;
    ... x 3 x 3 for arrays of angles."""
    psi, theta, phi = (
        np.deg2rad(np.asarray(a, np.float64)) for a in (heading_deg, pitch_deg, roll_deg)
    )
    psi, theta, phi = np.broadcast_arrays(psi, theta, phi)
    c, s = np.cos, np.sin
    one, zero = np.ones_like(psi), np.zeros_like(psi)
    rz = np.stack(
        [
            np.stack([c(psi), -s(psi), zero], -1),
            np.stack([s(psi), c(psi), zero], -1),
            np.stack([zero, zero, one], -1),
        ],
        -2,
    )
    ry = np.stack(
        [
            np.stack([c(theta), zero, s(theta)], -1),
            np.stack([zero, one, zero], -1),
            np.stack([-s(theta), zero, c(theta)], -1),
        ],
        -2,
    )
    rx = np.stack(
        [
            np.stack([one, zero, zero], -1),
            np.stack([zero, c(phi), -s(phi)], -1),
            np.stack([zero, s(phi), c(phi)], -1),
        ],
        -2,
    )
    return rz @ ry @ rx


def earth_pointing(
    azimuth_deg: Any, elevation_deg: Any, heading_deg: Any, pitch_deg: Any, roll_deg: Any
) -> tuple[np.ndarray, np.ndarray]:
    """A beam steered at (azimuth, elevation) in the array's frame, on the earth: azimuth
    clockwise from north in [0, 360) and elevation (deg)."""
    a, e = (
        np.deg2rad(np.asarray(azimuth_deg, np.float64)),
        np.deg2rad(np.asarray(elevation_deg, np.float64)),
    )
    body = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), -np.sin(e)], -1)
    ned = (attitude_matrix(heading_deg, pitch_deg, roll_deg) @ body[..., None])[..., 0]
    az = np.rad2deg(np.arctan2(ned[..., 1], ned[..., 0])) % 360.0
    el = np.rad2deg(np.arcsin(np.clip(-ned[..., 2], -1.0, 1.0)))
    return az, el


def beam_unit(azimuth_deg: Any, elevation_deg: Any) -> np.ndarray:
    """Unit vector (east, north, up) along a beam; ... x 3."""
    a, e = np.deg2rad(np.asarray(azimuth_deg)), np.deg2rad(np.asarray(elevation_deg))
    return np.stack([np.sin(a) * np.cos(e), np.cos(a) * np.cos(e), np.sin(e)], -1)


def velocity(p: dict[str, Any], t_s: np.ndarray) -> np.ndarray:
    """The platform's velocity (east, north, up; m/s) at times ``t_s`` after the start; t x 3."""
    given = [p[f"platform_velocity_{k}_ms"] for k in ("east", "north", "up")]
    if all(v is None for v in given):
        speed, psi = PRESETS[p["platform"]][1], np.deg2rad(p["platform_heading_deg"])
        v0 = np.array([speed * np.sin(psi), speed * np.cos(psi), 0.0])
    else:
        v0 = np.array([0.0 if v is None else float(v) for v in given])
    a = np.array([p[f"platform_acceleration_{k}_ms2"] for k in ("east", "north", "up")])
    return v0[None, :] + np.asarray(t_s, np.float64)[:, None] * a[None, :]


def attitude(p: dict[str, Any], t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Heading, pitch and roll (deg) at times ``t_s`` after the start (constant rates)."""
    t = np.asarray(t_s, np.float64)
    return tuple(  # type: ignore[return-value]
        p[f"platform_{k}_deg"] + p[f"platform_{k}_rate_deg_s"] * t
        for k in ("heading", "pitch", "roll")
    )


def carry(ds: xr.Dataset, p: dict[str, Any], mid_s: np.ndarray) -> xr.Dataset:
    """The beams of a chunk, steered in the array's frame, carried to the earth's through the
    platform's attitude at the middle of each dwell (``mid_s`` after the scan's start), with
    the platform's attitude, velocity and radial velocity on each beam."""
    heading, pitch, roll = attitude(p, mid_s)
    az_a, el_a = ds["azimuth"].values, ds["elevation"].values
    az, el = earth_pointing(az_a, el_a, heading, pitch, roll)
    v = velocity(p, mid_s)
    radial = np.einsum("bi,bi->b", v, beam_unit(az, el))
    out = ds.assign_coords(
        azimuth=("beam", az, ds["azimuth"].attrs), elevation=("beam", el, ds["elevation"].attrs)
    )
    deg = {"units": "degrees"}
    ms = {"units": "m s-1"}
    out = out.assign(
        array_azimuth=("beam", az_a, {**deg, "long_name": "azimuth steered in the array frame"}),
        array_elevation=("beam", el_a, {**deg, "long_name": "elevation in the array frame"}),
        heading=("beam", np.mod(heading, 360.0), {**deg, "long_name": "platform heading"}),
        pitch=("beam", pitch.astype(np.float64), {**deg, "long_name": "platform pitch"}),
        roll=("beam", roll.astype(np.float64), {**deg, "long_name": "platform roll"}),
        eastward_velocity=("beam", v[:, 0], {**ms, "long_name": "platform velocity east"}),
        northward_velocity=("beam", v[:, 1], {**ms, "long_name": "platform velocity north"}),
        vertical_velocity=("beam", v[:, 2], {**ms, "long_name": "platform velocity up"}),
        platform_radial_velocity=(
            "beam",
            radial,
            {**ms, "long_name": "platform velocity along the beam (toward the target)"},
        ),
    )
    out["platform_type"] = ((), PRESETS[p["platform"]][0])
    return out
