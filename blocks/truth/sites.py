"""Where a gate is when the radar stands somewhere else: gates placed from one site, read from
another's polar grid, on a spherical earth of radius a = 6371 km with 4/3-earth propagation.

A gate at range r, azimuth az and elevation el from a radar is at the height (above that radar)
and the ground distance of Doviak and Zrnic (1993, eq. 2.28b, c)::

    h = sqrt(r^2 + (k a)^2 + 2 r k a sin(el)) - k a,    s = k a asin(r cos(el) / (k a + h)),

and s along the great circle at az (:func:`destination`). Seen from
another radar at a ground distance s' and a height h' above it, the same point is on the
straight ray of the equivalent earth (radius k a) with central angle g = s' / (k a)::

    x = (k a + h') sin(g),   y = (k a + h') cos(g) - k a,   r' = hypot(x, y),  el' = atan2(y, x),

the exact inverse of the two equations above. A ray crosses the local horizontal of the gate at
el + s / (k a) (the central angle adds to the elevation on the equivalent earth), which is the
direction a wind is projected on.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .volume import EARTH_RADIUS_M, K_EARTH, beam_height, ground_range

KA = K_EARTH * EARTH_RADIUS_M


def destination(
    lat_deg: float, lon_deg: float, azimuth_deg: np.ndarray, distance_m: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Latitude and longitude (deg) ``distance_m`` along the great circle at ``azimuth_deg``."""
    lat1, lon1 = np.deg2rad(lat_deg), np.deg2rad(lon_deg)
    az, d = np.deg2rad(azimuth_deg), np.asarray(distance_m) / EARTH_RADIUS_M
    lat2 = np.arcsin(np.sin(lat1) * np.cos(d) + np.cos(lat1) * np.sin(d) * np.cos(az))
    lon2 = lon1 + np.arctan2(
        np.sin(az) * np.sin(d) * np.cos(lat1), np.cos(d) - np.sin(lat1) * np.sin(lat2)
    )
    return np.rad2deg(lat2), (np.rad2deg(lon2) + 180.0) % 360.0 - 180.0


def distance_bearing(
    lat1_deg: float | np.ndarray,
    lon1_deg: float | np.ndarray,
    lat2_deg: np.ndarray,
    lon2_deg: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Great-circle distance (m), initial bearing at point 1 and final bearing at point 2
    (deg clockwise from north) on the sphere of radius a."""
    p1, p2 = np.deg2rad(lat1_deg), np.deg2rad(lat2_deg)
    dl = np.deg2rad(np.asarray(lon2_deg) - np.asarray(lon1_deg))
    hav = np.sin((p2 - p1) / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin(dl / 2) ** 2
    d = 2 * EARTH_RADIUS_M * np.arcsin(np.sqrt(np.clip(hav, 0.0, 1.0)))
    y = np.sin(dl) * np.cos(p2)
    x = np.cos(p1) * np.sin(p2) - np.sin(p1) * np.cos(p2) * np.cos(dl)
    initial = np.rad2deg(np.arctan2(y, x)) % 360.0
    yb = np.sin(-dl) * np.cos(p1)
    xb = np.cos(p2) * np.sin(p1) - np.sin(p2) * np.cos(p1) * np.cos(dl)
    final = (np.rad2deg(np.arctan2(yb, xb)) + 180.0) % 360.0
    return d, initial, final


class Seen(NamedTuple):
    """Gates of one radar as another sees them (every array of the gates' shape)."""

    height_m: np.ndarray  # above the first radar's site
    latitude: np.ndarray
    longitude: np.ndarray
    range_m: np.ndarray  # from the other radar
    azimuth_deg: np.ndarray
    elevation_deg: np.ndarray
    ray_azimuth_deg: np.ndarray  # the first radar's ray at the gate, in the gate's own frame
    ray_elevation_deg: np.ndarray


def seen_from(
    site: tuple[float, float, float],
    other: tuple[float, float, float],
    range_m: np.ndarray,
    azimuth_deg: np.ndarray,
    elevation_deg: float,
) -> Seen:
    """Gates at ``range_m`` (gate) x ``azimuth_deg`` (radial) and ``elevation_deg`` from the
    radar at ``site`` (latitude, longitude, altitude above the datum in m), placed in three
    dimensions and given in range, azimuth and elevation from the radar at ``other``."""
    r = np.asarray(range_m, np.float64)[None, :]
    az = np.asarray(azimuth_deg, np.float64)[:, None]
    h = np.broadcast_to(beam_height(r, elevation_deg), (az.size, r.size))
    s = np.broadcast_to(ground_range(r, elevation_deg), h.shape)
    lat, lon = destination(site[0], site[1], np.broadcast_to(az, h.shape), s)
    _, _, ray_az = distance_bearing(site[0], site[1], lat, lon)
    ray_az = np.where(s > 0, ray_az, np.broadcast_to(az, h.shape))
    s2, az2, _ = distance_bearing(other[0], other[1], lat, lon)
    h2 = site[2] + h - other[2]
    g = s2 / KA
    x = (KA + h2) * np.sin(g)
    y = (KA + h2) * np.cos(g) - KA
    return Seen(
        height_m=h,
        latitude=lat,
        longitude=lon,
        range_m=np.hypot(x, y),
        azimuth_deg=az2,
        elevation_deg=np.rad2deg(np.arctan2(y, x)),
        ray_azimuth_deg=ray_az,
        ray_elevation_deg=elevation_deg + np.rad2deg(s / KA),
    )


def project_wind(
    east: np.ndarray,
    north: np.ndarray,
    up: np.ndarray,
    azimuth_deg: np.ndarray,
    elevation_deg: np.ndarray,
) -> np.ndarray:
    """Radial velocity (m/s, positive away) of a wind (east, north, up) on a ray crossing the
    gate at ``azimuth_deg`` and ``elevation_deg`` in the gate's own frame."""
    a, e = np.deg2rad(azimuth_deg), np.deg2rad(elevation_deg)
    return (east * np.sin(a) + north * np.cos(a)) * np.cos(e) + up * np.sin(e)


def offset_site(
    latitude: float, longitude: float, east_m: float, north_m: float
) -> tuple[float, float]:
    """The site ``east_m`` east and ``north_m`` north of another, along the great circle at
    their bearing (the ground distance hypot(east, north))."""
    d = float(np.hypot(east_m, north_m))
    bearing = float(np.rad2deg(np.arctan2(east_m, north_m)))
    lat, lon = destination(latitude, longitude, np.asarray(bearing), np.asarray(d))
    return float(lat), float(lon)
