"""The steered planar array of patches: array factor, fields, power and directivity.

:func:`planar_array_power` is a uniform rectangular array of dual-polarised square patches
(paper section 2.2.1) with a separable Taylor taper (section 2.2.2), steered by ideal phase
shifters. The complex element weights are an explicit intermediate
(:func:`pasim_blocks.antennas.tapers.planar_array_weights`) so that phase-shifter
quantisation, channel-to-channel errors and failed elements can be applied to them before
:func:`array_factor` is evaluated. Angles at the public interface are in degrees; azimuth is
clockwise from north and elevation is above the horizon. The global frame is east-north-up.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

from ..signals import SPEED_OF_LIGHT
from .geometry import DualPolField, FaceGeometry, face_geometry, patch_field
from .hermite import hermite_eval, hermite_table
from .tapers import (
    SeparableWeights,
    planar_array_weights,
    taper_efficiency,
    taylor_taper,
)

# Oversampling of the array-factor lookup table relative to the number of elements. The table
# holds a trigonometric polynomial of frequencies up to n/2; with 128 samples per element and
# cubic Hermite interpolation the error is ~(pi/128)^4/384 ~ 1e-9 of the array's coherent sum.
_AF_OVERSAMPLING = 128
# Points per block in the exact (non-separable) array-factor path: bounds the temporary
# (points x elements) matrices to a few megabytes so they stay cache friendly.
_AF_CHUNK = 2048


def _powers(z: NDArray[np.complex128], n: int, out: NDArray[np.complex128]) -> NDArray:
    """``z[:, None] ** arange(n)`` by a running product (a complex exp per entry is 10x slower)."""
    out[:, 0] = 1.0
    out[:, 1:] = z[:, None]
    return np.cumprod(out, axis=1, out=out)


def _linear_array_factor(weights: NDArray, psi: NDArray) -> NDArray[np.complex128]:
    """``F(psi) = sum_m w_m exp(j (m - c) psi)``, ``c = (n - 1) / 2``, at any phase increments.

    ``F`` is a trigonometric polynomial with ``F(psi + 2 pi) = (-1)^(n-1) F(psi)``, so one
    zero-padded FFT tabulates it (and, with the weights multiplied by ``j (m - c)``, its
    derivative) over one period; cubic Hermite interpolation then costs a few operations per
    direction instead of one complex exponential per element and direction. Tabulating the
    centred sum rather than ``sum_m w_m exp(j m psi)`` halves its bandwidth, which cuts the
    interpolation error sixteen-fold.
    """
    weights = np.asarray(weights, dtype=complex)
    n = weights.size
    size = 1 << int(np.ceil(np.log2(max(_AF_OVERSAMPLING * n, 64))))
    centred = np.arange(n) - 0.5 * (n - 1)
    # size * ifft(a, size)[k] = sum_m a_m exp(j m psi_k) on psi_k = 2 pi k / size; the closing
    # sample k = size makes the last interval complete.
    grid_phase = np.exp(-0.5j * (n - 1) * (2.0 * np.pi / size) * np.arange(size + 1))
    spectra = np.fft.ifft(np.stack([weights, 1j * centred * weights]), size, axis=1) * size
    spectra = np.concatenate([spectra, spectra[:, :1]], axis=1) * grid_phase
    table = hermite_table(spectra[0], spectra[1] * (2.0 * np.pi / size))
    turns = np.floor(psi / (2.0 * np.pi))
    f = hermite_eval(table, (psi / (2.0 * np.pi) - turns) * size)
    if n % 2 == 0:
        # Half-integer element offsets: every period crossed flips the sign.
        f *= 1.0 - 2.0 * np.mod(turns, 2.0)
    return f


def _general_array_factor(weights: NDArray, psi_x: NDArray, psi_y: NDArray) -> NDArray:
    """Exact ``sum_mn W[m, n] exp(j (m - cx) psi_x + j (n - cy) psi_y)`` for any ``W``."""
    n_x, n_y = weights.shape
    flat_x, flat_y = psi_x.ravel(), psi_y.ravel()
    out = np.empty(flat_x.size, dtype=complex)
    x_pow = np.empty((_AF_CHUNK, n_x), dtype=complex)
    y_pow = np.empty((_AF_CHUNK, n_y), dtype=complex)
    # Loop over blocks of directions only; each block is two BLAS-sized products.
    for start in range(0, flat_x.size, _AF_CHUNK):
        sl = slice(start, start + _AF_CHUNK)
        count = flat_x[sl].size
        xp = _powers(np.exp(1j * flat_x[sl]), n_x, x_pow[:count])
        yp = _powers(np.exp(1j * flat_y[sl]), n_y, y_pow[:count])
        out[sl] = np.einsum("pm,pm->p", xp, yp @ weights.T)
    centre = np.exp(-0.5j * ((n_x - 1) * flat_x + (n_y - 1) * flat_y))
    return (out * centre).reshape(psi_x.shape)


def _rows_array_factor(weights: NDArray, psi_x: NDArray, psi_y: NDArray) -> NDArray:
    """Exact array factor on a grid whose ``psi_y`` is one value per row of ``psi_x``.

    The sum over the ``n_y`` rows of elements is done once per grid row (a matrix product);
    what remains per grid row is the polynomial ``sum_m B_m z^m`` in ``z = exp(j psi_x)``,
    evaluated by Horner's rule over the whole grid at once (``n_x`` contiguous multiply-adds).
    """
    n_x, n_y = weights.shape
    centred_y = np.arange(n_y) - 0.5 * (n_y - 1)
    per_row = np.exp(1j * np.outer(psi_y, centred_y)) @ weights.T  # rows x n_x
    z = np.exp(1j * psi_x)
    out = np.broadcast_to(per_row[:, n_x - 1 : n_x], psi_x.shape).astype(complex)
    for m in range(n_x - 2, -1, -1):
        out *= z
        out += per_row[:, m : m + 1]
    return out * np.exp(-0.5j * (n_x - 1) * psi_x)


def array_factor(
    u: npt.ArrayLike,
    v: npt.ArrayLike,
    weights: SeparableWeights | npt.ArrayLike,
    *,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
) -> NDArray[np.complex128]:
    """Complex array factor of a rectangular planar array, phase referenced to its centre.

    ``AF(u, v) = sum_mn W[m, n] exp(j k (x_m u + y_n v))``.

    Parameters
    ----------
    u, v : array_like
        Face direction cosines (see :func:`face_direction_cosines`); broadcast together.
    weights : SeparableWeights or array_like
        Either separable weights (fast path: ``AF_x(u) * AF_y(v)``, each from an FFT table,
        about 1e-10 relative accuracy) or a full ``(n_x, n_y)`` complex matrix (exact path,
        cost proportional to directions x elements; use it for non-separable perturbations).
    dx_m, dy_m : float
        Element spacings, metres.
    frequency_hz : float
        Frequency, Hz.

    Returns
    -------
    ndarray
        Complex array factor, shape of the broadcast ``u`` and ``v``; its magnitude in the
        steering direction is ``|sum W|``.
    """
    k = 2.0 * np.pi * frequency_hz / SPEED_OF_LIGHT
    psi_x = k * dx_m * np.asarray(u, dtype=float)
    psi_y = k * dy_m * np.asarray(v, dtype=float)
    if isinstance(weights, SeparableWeights):
        # Each factor on its own (unbroadcast) shape: on an az x el grid of an untilted face
        # v depends on elevation only, so AF_y costs one row instead of the whole grid.
        af_x = _linear_array_factor(weights.x, psi_x)
        af_y = _linear_array_factor(weights.y, psi_y)
        return np.asarray(af_x * af_y)
    full = np.asarray(weights, dtype=complex)
    if full.ndim != 2:
        raise ValueError(f"weights must be SeparableWeights or a 2-D matrix, got {full.shape}")
    if psi_x.ndim == 2 and psi_y.ndim == 2 and psi_y.shape[1] == 1:
        # A grid whose v depends on the row only (an untilted face): sum over rows once.
        return _rows_array_factor(full, psi_x, psi_y[:, 0])
    psi_x, psi_y = np.broadcast_arrays(psi_x, psi_y)
    return _general_array_factor(full, psi_x, psi_y)


# --------------------------------------------------------------------------------------------
# Planar array patterns
# --------------------------------------------------------------------------------------------


def planar_array_fields(
    az_deg: npt.ArrayLike,
    el_deg: npt.ArrayLike,
    *,
    weights: SeparableWeights | npt.ArrayLike,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    patch_m: float,
    face_azimuth_deg: float = 0.0,
    face_tilt_deg: float = 0.0,
) -> DualPolField:
    """Far field of a planar patch array for given element weights (all four components).

    Element field times array factor, normalised so that an array with the same weight
    magnitudes steered to broadside has an H co-polar amplitude of 1 on its axis. Both ports
    use the same weights; separate H and V channel errors will need one weight set per port.

    Parameters
    ----------
    az_deg, el_deg : array_like
        Directions, degrees; broadcast together.
    weights : SeparableWeights or array_like
        Element weights (see :func:`planar_array_weights`, :func:`array_factor`).
    dx_m, dy_m, frequency_hz, patch_m : float
        Spacings (m), frequency (Hz) and patch side (m).
    face_azimuth_deg, face_tilt_deg : float, optional
        Orientation of the face.

    Returns
    -------
    DualPolField
        Complex components on the local (h, v) basis.
    """
    af, element = _array_and_element(
        az_deg, el_deg, weights, dx_m, dy_m, frequency_hz, patch_m, face_azimuth_deg, face_tilt_deg
    )
    return DualPolField(*(af * component for component in element))


def array_fields(
    geometry: FaceGeometry,
    element: object,
    weights_h: SeparableWeights | npt.ArrayLike,
    weights_v: SeparableWeights | npt.ArrayLike | None = None,
    *,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    norm: float,
) -> DualPolField:
    """Far field of a planar array with one weight set per port (all four components).

    ``AF_H E_H`` and ``AF_V E_V``, each array factor divided by ``norm`` (the design's
    broadside-steered coherent sum, so that channel errors and failures lower the peak).

    Parameters
    ----------
    geometry : FaceGeometry
        Directions in the face frame (:func:`face_geometry`).
    element : object
        Element model with ``field(geometry) -> DualPolField``
        (:mod:`pasim_blocks.antennas.elements`).
    weights_h, weights_v : SeparableWeights or array_like
        Weights of the H and V ports (``weights_v`` None: the same as H).
    dx_m, dy_m, frequency_hz : float
        Spacings (m) and frequency (Hz).
    norm : float
        Divisor of both array factors.

    Returns
    -------
    DualPolField
        Complex components on the local (h, v) basis.
    """
    common = {"dx_m": dx_m, "dy_m": dy_m, "frequency_hz": frequency_hz}
    af_h = array_factor(geometry.u, geometry.v, weights_h, **common) / norm
    af_v = af_h if weights_v is None else array_factor(geometry.u, geometry.v, weights_v, **common)
    if weights_v is not None:
        af_v = af_v / norm
    e = element.field(geometry)  # type: ignore[attr-defined]
    return DualPolField(af_h * e.h_co, af_h * e.h_cross, af_v * e.v_co, af_v * e.v_cross)


def _array_and_element(
    az_deg: npt.ArrayLike,
    el_deg: npt.ArrayLike,
    weights: SeparableWeights | npt.ArrayLike,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    patch_m: float,
    face_azimuth_deg: float,
    face_tilt_deg: float,
) -> tuple[NDArray[np.complex128], DualPolField]:
    """Normalised array factor and element field, apart so callers multiply only what they use."""
    geometry = face_geometry(az_deg, el_deg, face_azimuth_deg, face_tilt_deg)
    af = array_factor(
        geometry.u, geometry.v, weights, dx_m=dx_m, dy_m=dy_m, frequency_hz=frequency_hz
    )
    # The broadside-steered peak is sum |W| (all elements in phase, element pattern 1 there).
    if isinstance(weights, SeparableWeights):
        coherent = np.abs(weights.x).sum() * np.abs(weights.y).sum()
    else:
        coherent = np.abs(np.asarray(weights)).sum()
    af /= coherent
    return af, patch_field(geometry, patch_m * frequency_hz / SPEED_OF_LIGHT)


def planar_array_power(
    az_deg: npt.ArrayLike,
    el_deg: npt.ArrayLike,
    *,
    steer_az_deg: float,
    steer_el_deg: float,
    n_x: int,
    n_y: int,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    patch_m: float,
    taylor_sll_db: float,
    taylor_nbar: int,
    face_azimuth_deg: float = 0.0,
    face_tilt_deg: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One-way co-polar power patterns of a steered planar array of dual-polarised patches.

    Parameters
    ----------
    az_deg, el_deg : array_like
        Absolute directions (azimuth clockwise from north, elevation), degrees; broadcast.
    steer_az_deg, steer_el_deg : float
        Steering direction, degrees.
    n_x, n_y : int
        Elements along the face horizontal and vertical.
    dx_m, dy_m : float
        Element spacings, metres.
    frequency_hz : float
        Frequency, Hz.
    patch_m : float
        Side of the square patch, metres.
    taylor_sll_db : float
        Taylor design sidelobe level, dB (sign ignored).
    taylor_nbar : int
        Taylor ``nbar``.
    face_azimuth_deg, face_tilt_deg : float, optional
        Azimuth and upward tilt of the face normal, degrees.

    Returns
    -------
    p_h, p_v : ndarray
        Power patterns of the H and V ports (co-polar components), both normalised to the
        peak of the broadside-steered H pattern, so scan loss shows as a peak below 1 and the
        H/V mismatch off broadside as ``p_h / p_v != 1``.
    """
    weights = planar_array_weights(
        steer_az_deg=steer_az_deg,
        steer_el_deg=steer_el_deg,
        n_x=n_x,
        n_y=n_y,
        dx_m=dx_m,
        dy_m=dy_m,
        frequency_hz=frequency_hz,
        taylor_sll_db=taylor_sll_db,
        taylor_nbar=taylor_nbar,
        face_azimuth_deg=face_azimuth_deg,
        face_tilt_deg=face_tilt_deg,
    )
    af, element = _array_and_element(
        az_deg, el_deg, weights, dx_m, dy_m, frequency_hz, patch_m, face_azimuth_deg, face_tilt_deg
    )
    # This element model is real, so |AF E|^2 = |AF|^2 E^2 and the cross-polar terms are skipped.
    af_power = af.real**2 + af.imag**2
    return np.asarray(af_power * element.h_co**2), np.asarray(af_power * element.v_co**2)


def planar_array_directivity_db(
    *,
    n_x: int,
    n_y: int,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    taylor_sll_db: float,
    taylor_nbar: int,
) -> float:
    """Broadside directivity of a Taylor-tapered planar array from its aperture.

    ``10 log10(4 pi (n_x dx)(n_y dy) / lambda^2 * eta)`` with the taper efficiency
    ``eta = |sum w|^2 / (N sum |w|^2)`` of the separable weights.

    Parameters
    ----------
    n_x, n_y : int
        Numbers of elements.
    dx_m, dy_m : float
        Element spacings, metres.
    frequency_hz : float
        Frequency, Hz.
    taylor_sll_db : float
        Taylor design sidelobe level, dB (sign ignored).
    taylor_nbar : int
        Taylor ``nbar``.

    Returns
    -------
    float
        Directivity, dBi.
    """
    wavelength = SPEED_OF_LIGHT / frequency_hz
    area = n_x * dx_m * n_y * dy_m
    eta = taper_efficiency(taylor_taper(n_x, taylor_sll_db, taylor_nbar)) * taper_efficiency(
        taylor_taper(n_y, taylor_sll_db, taylor_nbar)
    )
    return float(10.0 * np.log10(4.0 * np.pi * area / wavelength**2 * eta))
