"""The echo seen from a moving platform (:mod:`pasim_blocks.scans.platform`).

Radial velocity: a scatterer at rest seen from a radar moving with velocity v_p is approached
at v_p . u (u the beam's unit vector), so every cell's radial velocity relative to the radar
is its own minus ``platform_radial_velocity``. The channel applies it to the whole echo of a
beam as the Doppler phase exp(j 4 pi v_p t / lambda) on each pulse at time t (and the
correlations at lag k by exp(j 4 pi v_p k T / lambda)): the pulse-pair velocity, -lambda /
(4 pi T) arg R(T), moves by -v_p.

Broadening: across the beam the direction to a scatterer turns away from the axis by a small
angle theta, and the platform's velocity across the beam, v_perp, adds v_perp sin(theta) to
its radial velocity. Weighted by a Gaussian two-way power pattern of one-way 3-dB width
theta_1 that is a Gaussian spectrum of width (Doviak and Zrnic 1993, section 5.3; Sloss and
Atlas 1968)

    sigma_p = v_perp theta_1 / (4 sqrt(ln 2)) = 0.300 v_perp theta_1,

added in quadrature to the others. The channel takes v_perp in the beam's azimuth and
elevation directions apart, each with the beam's own one-way 3-dB width in that direction,
measured on its H pattern: sigma_p^2 = ((v_az theta_az)^2 + (v_el theta_el)^2) / (16 ln 2).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from .clutter import one_way_beamwidth

#: The lag (in pulses) of each of CORRELATION_PRODUCTS, in its order.
LAGS = np.array([0, 0, 1, 1, 0, 2, 2, 1, 1])


def moving(beams: xr.Dataset) -> bool:
    return "platform_radial_velocity" in beams


def motion_width(v_az: Any, v_el: Any, az_width_deg: Any, el_width_deg: Any) -> Any:
    """sigma_p (m/s) of a platform moving across the beam at ``v_az`` and ``v_el`` (m/s) with
    one-way 3-dB widths (deg) in those directions."""
    a, e = np.deg2rad(az_width_deg), np.deg2rad(el_width_deg)
    return np.sqrt((v_az * a) ** 2 + (v_el * e) ** 2) / (4.0 * np.sqrt(np.log(2.0)))


def platform_broadening(beams: xr.Dataset, pattern: xr.Dataset, scan: np.ndarray) -> np.ndarray:
    """Each beam's broadening (m/s): its scan modulation ``scan`` and, on a moving platform,
    sigma_p in quadrature, rounded to 1e-4 m/s as the scan modulation is; ``scan`` itself on
    a still radar."""
    if not moving(beams):
        return scan
    az = np.deg2rad(beams["azimuth"].values)
    el = np.deg2rad(beams["elevation"].values)
    v = np.stack(
        [beams[k].values for k in ("eastward_velocity", "northward_velocity", "vertical_velocity")],
        -1,
    )
    e_az = np.stack([np.cos(az), -np.sin(az), np.zeros_like(az)], -1)
    e_el = np.stack([-np.sin(az) * np.sin(el), -np.cos(az) * np.sin(el), np.cos(el)], -1)
    d_az = pattern["azimuth_offset_deg"].values
    d_el = pattern["elevation_offset_deg"].values
    power = pattern["power"].values
    out = np.empty(az.size)
    for i in range(az.size):
        # Azimuth offsets are angles in azimuth: across the beam they shrink by cos(el).
        w_az = one_way_beamwidth(power[i, 0], d_az, d_el) * np.cos(el[i])
        w_el = one_way_beamwidth(power[i, 0].T, d_el, d_az)
        sigma = motion_width(np.dot(v[i], e_az[i]), np.dot(v[i], e_el[i]), w_az, w_el)
        out[i] = np.hypot(scan[i], sigma)
    return np.round(out, 4)


def shift_echo(
    iq: np.ndarray,
    corr: np.ndarray,
    beams: xr.Dataset,
    times_s: np.ndarray,
    prt_s: float,
    wavelength_m: float,
) -> None:
    """The Doppler of the platform's motion on each beam's echo, in place: the I/Q (beam x
    channel x gate x pulse) at pulse times ``times_s`` and the correlations (beam x gate x
    product) at their lags of ``prt_s``."""
    vp = beams["platform_radial_velocity"].values
    k = 4.0 * np.pi / wavelength_m
    if iq.shape[-1]:
        iq *= np.exp(1j * k * vp[:, None] * times_s[None, :]).astype(iq.dtype)[:, None, None, :]
    corr *= np.exp(1j * k * vp[:, None] * LAGS[None, :] * prt_s)[:, None, :]
