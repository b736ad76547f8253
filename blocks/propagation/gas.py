"""Gaseous attenuation along a beam: oxygen and water vapour at the radar's frequency.

Specific attenuations at sea level from the simplified closed forms of ITU-R P.676 (Annex 2
of the editions around P.676-5, valid below 57 GHz for oxygen and below 350 GHz for water
vapour) for the reference atmosphere of 15 deg C, 1013.25 hPa and 7.5 g/m^3 of water vapour;
each decays with height above sea level as exp(-h / h_0) with P.676's equivalent heights
(6 km for oxygen, 1.6 km for water vapour). h is the beam's height by the 4/3-earth model
(Doviak and Zrnic 1993, eq. 2.28b) plus the site's altitude. At 2.8 GHz this gives about
0.0073 dB/km one way at sea level (0.015 dB/km two-way), 0.0087 at 5.6 GHz, 0.012 at 9.4
GHz.
"""

from __future__ import annotations

import numpy as np

EARTH_RADIUS_M = 6_371_000.0
#: Effective earth radius factor of the standard refraction model.
K_EFFECTIVE = 4.0 / 3.0
#: Equivalent heights (m) of oxygen and water vapour (ITU-R P.676, below 50 GHz).
OXYGEN_HEIGHT_M = 6000.0
VAPOUR_HEIGHT_M = 1600.0
#: Reference atmosphere: temperature (deg C), pressure (hPa), water vapour (g/m^3).
REFERENCE = (15.0, 1013.25, 7.5)


def specific_attenuation(frequency_hz: float) -> tuple[float, float]:
    """One-way specific attenuation (dB/km) of oxygen and of water vapour at sea level."""
    f = frequency_hz / 1e9
    t_c, p_hpa, rho = REFERENCE
    rt, rp = 288.0 / (273.0 + t_c), p_hpa / 1013.0
    oxygen = (
        7.27 * rt / (f**2 + 0.351 * rp**2 * rt**2) + 7.5 / ((f - 57.0) ** 2 + 2.44 * rp**2 * rt**5)
    ) * (f**2 * rp**2 * rt**2 * 1e-3)
    vapour = (
        3.27e-2 * rt
        + 1.67e-3 * rho * rt**7 / rp
        + 7.7e-4 * np.sqrt(f)
        + 3.79 / ((f - 22.235) ** 2 + 9.81 * rp**2 * rt)
        + 11.73 * rt / ((f - 183.31) ** 2 + 11.85 * rp**2 * rt)
        + 4.01 * rt / ((f - 325.153) ** 2 + 10.44 * rp**2 * rt)
    ) * (f**2 * rho * rp * rt * 1e-4)
    return float(oxygen), float(vapour)


def beam_height_m(range_m: np.ndarray, elevation_deg: float) -> np.ndarray:
    """Height of the beam above the radar (4/3 earth)."""
    ka = K_EFFECTIVE * EARTH_RADIUS_M
    el = np.deg2rad(elevation_deg)
    return np.sqrt(range_m**2 + ka**2 + 2 * range_m * ka * np.sin(el)) - ka


def two_way_gas_db(
    frequency_hz: float, range_m: np.ndarray, elevation_deg: float, altitude_m: float
) -> np.ndarray:
    """Two-way gaseous attenuation (dB) from the radar to each range (trapezoids from 0)."""
    oxygen, vapour = specific_attenuation(frequency_hz)
    r = np.concatenate([[0.0], np.asarray(range_m, np.float64)])
    h = altitude_m + beam_height_m(r, elevation_deg)
    gamma = oxygen * np.exp(-h / OXYGEN_HEIGHT_M) + vapour * np.exp(-h / VAPOUR_HEIGHT_M)
    from scipy.integrate import cumulative_trapezoid  # (imported late: see rain.py)

    return 2 * cumulative_trapezoid(gamma, r / 1e3)
