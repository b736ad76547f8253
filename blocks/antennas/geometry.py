"""Planar array geometry (face frames, direction cosines) and the dual-polarised patch element.

Azimuth is clockwise from north and elevation is above the horizon; the global frame is
east-north-up.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

from ..signals import SPEED_OF_LIGHT


class FaceGeometry(NamedTuple):
    """Directions in a face frame, plus the face axes projected on the local (h, v) basis."""

    u: NDArray
    v: NDArray
    w: NDArray
    x_dot_h: NDArray
    x_dot_v: NDArray
    y_dot_h: NDArray
    y_dot_v: NDArray


def face_geometry(
    az_deg: npt.ArrayLike, el_deg: npt.ArrayLike, face_azimuth_deg: float, face_tilt_deg: float
) -> FaceGeometry:
    """Everything the element and array models need from the directions, trig done once."""
    d_az = np.radians(np.asarray(az_deg, dtype=float) - face_azimuth_deg)
    el = np.radians(np.asarray(el_deg, dtype=float))
    tilt = np.radians(face_tilt_deg)
    cos_d, sin_d = np.cos(d_az), np.sin(d_az)
    cos_el, sin_el = np.cos(el), np.sin(el)
    cos_t, sin_t = np.cos(tilt), np.sin(tilt)
    horizontal_normal = cos_el * cos_d  # component along the untilted normal
    # Untilted faces keep v a function of elevation only (and its shape), which the separable
    # array factor exploits.
    v = sin_el if tilt == 0.0 else cos_t * sin_el - sin_t * horizontal_normal
    # The face x axis is horizontal whatever the tilt; y = x cross normal is "up the face".
    return FaceGeometry(
        u=cos_el * sin_d,
        v=v,
        w=sin_t * sin_el + cos_t * horizontal_normal,
        x_dot_h=cos_d,
        x_dot_v=-sin_el * sin_d,
        y_dot_h=sin_t * sin_d,
        y_dot_v=cos_t * cos_el + sin_t * sin_el * cos_d,
    )


def face_direction_cosines(
    az_deg: npt.ArrayLike,
    el_deg: npt.ArrayLike,
    *,
    face_azimuth_deg: float = 0.0,
    face_tilt_deg: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Direction cosines of absolute directions in the frame of an array face.

    The face frame has ``x`` horizontal along the face (to the right seen from behind the
    array, i.e. towards increasing azimuth), ``y`` up along the face and the normal pointing
    at azimuth ``face_azimuth_deg``, tilted up by ``face_tilt_deg``. For zero tilt,
    ``u = cos(el) sin(az - face_az)`` and ``v = sin(el)``.

    Parameters
    ----------
    az_deg, el_deg : array_like
        Azimuth (clockwise from north) and elevation of the directions, degrees; broadcast.
    face_azimuth_deg : float, optional
        Azimuth of the face normal, degrees.
    face_tilt_deg : float, optional
        Upward tilt of the face normal, degrees.

    Returns
    -------
    u, v, w : ndarray
        Components along the face ``x``, ``y`` and normal; ``w > 0`` in front of the face.
    """
    g = face_geometry(az_deg, el_deg, face_azimuth_deg, face_tilt_deg)
    u, v, w = np.broadcast_arrays(g.u, g.v, g.w)
    return np.array(u), np.array(v), np.array(w)


def behind_face(
    az_deg: np.ndarray, el_deg: np.ndarray, face_azimuth_deg: float, face_tilt_deg: float
) -> str | None:
    """The beams of a scan that lie behind a face (no steering reaches them), in words with
    what the face reaches; None when every beam is in front of it."""
    _, _, w = face_direction_cosines(
        az_deg, el_deg, face_azimuth_deg=face_azimuth_deg, face_tilt_deg=face_tilt_deg
    )
    behind = ~(w > 0.0)
    if not behind.any():
        return None
    # Azimuths behind the face lie within 90 deg of its back: measured from there, they
    # neither wrap through north nor through the back, so their extremes are the span.
    back = (face_azimuth_deg + 180.0) % 360.0
    rel = (np.asarray(az_deg, float)[behind] - back + 180.0) % 360.0 - 180.0
    el = np.asarray(el_deg, float)[behind]
    first, last = (back + rel.min()) % 360.0, (back + rel.max()) % 360.0
    span = f"{first:.1f}" if first == last else f"{first:.1f} to {last:.1f}"
    els = f"{el.min():.1f}" if el.min() == el.max() else f"{el.min():.1f} to {el.max():.1f}"
    # In front: w = cos(el) cos(tilt) cos(daz) + sin(el) sin(tilt) > 0 at the lowest elevation.
    low = np.deg2rad(el.min())
    tilt = np.deg2rad(face_tilt_deg)
    bound = -np.tan(low) * np.tan(tilt)
    if bound >= 1.0:
        reach = f"no azimuth at elevation {el.min():.1f} deg"
    elif bound <= -1.0:
        reach = f"every azimuth at elevation {el.min():.1f} deg"
    else:
        half = float(np.rad2deg(np.arccos(bound)))
        lo, hi = (face_azimuth_deg - half) % 360.0, (face_azimuth_deg + half) % 360.0
        reach = f"azimuth {lo:.1f} to {hi:.1f} deg (clockwise) at elevation {el.min():.1f} deg"
    return (
        f"{int(behind.sum())} of the scan's {behind.size} beams, azimuth {span} deg at "
        f"elevation {els} deg, are behind the face (normal at azimuth {face_azimuth_deg:g} "
        f"deg, tilt {face_tilt_deg:g} deg), which steers only in front of it: {reach}"
    )


class DualPolField(NamedTuple):
    """Far-field components of the two ports of a dual-polarised element or array.

    Components are taken on the radar's local polarisation basis at each direction:
    ``h`` is the unit vector of increasing azimuth (horizontal) and ``v`` that of increasing
    elevation.

    Attributes
    ----------
    h_co : ndarray
        H port, component along ``h`` (co-polar).
    h_cross : ndarray
        H port, component along ``v`` (cross-polar).
    v_co : ndarray
        V port, component along ``v`` (co-polar).
    v_cross : ndarray
        V port, component along ``h`` (cross-polar).
    """

    h_co: NDArray
    h_cross: NDArray
    v_co: NDArray
    v_cross: NDArray


def patch_element_field(
    az_deg: npt.ArrayLike,
    el_deg: npt.ArrayLike,
    *,
    patch_m: float,
    frequency_hz: float,
    face_azimuth_deg: float = 0.0,
    face_tilt_deg: float = 0.0,
) -> DualPolField:
    """Far field of a square dual-polarised patch from the two-slot cavity model.

    Each port of a square patch of side ``L`` is modelled (Balanis, *Antenna Theory*, ch. 14,
    cavity/transmission-line model) as two in-phase radiating slots ``L`` long, a distance
    ``L`` apart, over an infinite ground plane. For the H port the patch current runs along the
    face ``x`` axis, so the equivalent magnetic currents run along ``y`` and the field is

    ``E_H = cos(k L u / 2) * sinc(k L v / 2) * (r x y_face)``, with ``|r x y_face| = sqrt(1 - v^2)``

    (the slot-pair factor gives the E-plane pattern, the slot length the H-plane one; the slot
    height is taken as negligible). The V port is the same with ``x`` and ``y`` exchanged:
    ``E_V = cos(k L v / 2) * sinc(k L u / 2) * (x_face x r)``. Both are 1 at broadside and zero
    behind the face (the ground plane blocks the rear hemisphere). The slots are at the
    patch's radiating edges with no substrate, so ``L`` is also the slot separation.

    This is the isolated-element pattern, used as the element gain pattern of the array. For
    ``L`` near half a wavelength its E-plane factor falls faster than the ``cos(theta)`` of an
    element embedded in a large matched array: at 45 degrees azimuth the H port is down
    6.6 dB and the V port 4.8 dB for the paper's 5.24 cm patch at 2.8 GHz.

    Parameters
    ----------
    az_deg, el_deg : array_like
        Directions (absolute azimuth and elevation), degrees; broadcast together.
    patch_m : float
        Patch side ``L``, metres (the paper's patch is 0.0524 m).
    frequency_hz : float
        Frequency, Hz.
    face_azimuth_deg, face_tilt_deg : float, optional
        Orientation of the array face (see :func:`face_direction_cosines`).

    Returns
    -------
    DualPolField
        Real field components on the local (h, v) basis, normalised to 1 at broadside.
    """
    geometry = face_geometry(az_deg, el_deg, face_azimuth_deg, face_tilt_deg)
    return patch_field(geometry, patch_m * frequency_hz / SPEED_OF_LIGHT)


def patch_field(g: FaceGeometry, size: float) -> DualPolField:
    """Cavity-model field of a patch ``size`` wavelengths square (see patch_element_field)."""
    front = g.w > 0.0
    # np.sinc(x) = sin(pi x) / (pi x), so sinc(k L v / 2) = np.sinc(L v / lambda).
    s_h = np.where(front, np.cos(np.pi * size * g.u) * np.sinc(size * g.v), 0.0)
    s_v = np.where(front, np.cos(np.pi * size * g.v) * np.sinc(size * g.u), 0.0)
    # Project E_H ~ r x y and E_V ~ x x r on the local basis; (v, h, r) is right-handed, so
    # (r x y)·h = y·v, (r x y)·v = -y·h, (x x r)·v = x·h and (x x r)·h = -x·v.
    return DualPolField(
        h_co=s_h * g.y_dot_v,
        h_cross=-s_h * g.y_dot_h,
        v_co=s_v * g.x_dot_h,
        v_cross=-s_v * g.x_dot_v,
    )
