"""Array weights: element positions, amplitude tapers (Taylor, Kaiser, uniform) and steering."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

from ..signals import SPEED_OF_LIGHT
from .geometry import face_direction_cosines


class SeparableWeights(NamedTuple):
    """Complex element weights of a planar array that factor as ``W[m, n] = x[m] * y[n]``.

    Attributes
    ----------
    x : ndarray
        Complex weights of the ``n_x`` columns (horizontal positions).
    y : ndarray
        Complex weights of the ``n_y`` rows (vertical positions).
    """

    x: NDArray[np.complex128]
    y: NDArray[np.complex128]

    def full(self) -> NDArray[np.complex128]:
        """The ``(n_x, n_y)`` weight matrix, for perturbations that break separability."""
        return np.outer(self.x, self.y)


def element_positions(n: int, spacing_m: float) -> NDArray[np.float64]:
    """Positions of ``n`` equally spaced elements centred on the array centre, metres."""
    return (np.arange(n, dtype=np.float64) - (n - 1) / 2.0) * spacing_m


def taylor_taper(n: int, sll_db: float, nbar: int) -> NDArray[np.float64]:
    """Taylor amplitude taper of ``n`` elements (``scipy.signal.windows.taylor``).

    Parameters
    ----------
    n : int
        Number of elements.
    sll_db : float
        Design sidelobe level in dB; the sign is ignored (-30 and 30 both mean 30 dB down).
    nbar : int
        Number of nearly equal sidelobes next to the main lobe.

    Returns
    -------
    ndarray
        Real, symmetric weights.
    """
    # scipy.signal is imported where it is used: at the top, every command that only reads
    # a graph (validate, blocks, --help) paid for importing it.
    from scipy.signal import windows

    return np.asarray(
        windows.taylor(n, nbar=nbar, sll=abs(sll_db), norm=True, sym=True), dtype=float
    )


def taper_efficiency(weights: npt.ArrayLike) -> float:
    """Taper efficiency ``|sum w|^2 / (N sum |w|^2)`` of any weight vector or matrix."""
    w = np.asarray(weights)
    return float(abs(w.sum()) ** 2 / (w.size * np.sum(np.abs(w) ** 2)))


#: Amplitude tapers an array block can choose (its ``taper`` parameter).
TAPERS = ("taylor", "kaiser", "uniform")


def design_taper(
    n: int, kind: str, sll_db: float = -30.0, nbar: int = 5, beta: float = 4.0
) -> NDArray[np.float64]:
    """Amplitude taper of ``n`` elements, peak 1: Taylor (``sll_db``, ``nbar``), Kaiser
    (``beta``) or uniform, from ``scipy.signal.windows``."""
    if kind == "taylor":
        return taylor_taper(n, sll_db, nbar)
    if kind == "kaiser":
        from scipy.signal import windows

        w = windows.kaiser(n, beta, sym=True)
        return np.asarray(w / w.max(), dtype=float)
    if kind == "uniform":
        return np.ones(n)
    raise ValueError(f"unknown taper {kind!r}; known: {', '.join(TAPERS)}")


def planar_array_weights(
    *,
    steer_az_deg: float,
    steer_el_deg: float,
    n_x: int,
    n_y: int,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    taylor_sll_db: float,
    taylor_nbar: int,
    face_azimuth_deg: float = 0.0,
    face_tilt_deg: float = 0.0,
) -> SeparableWeights:
    """Taylor-tapered, phase-steered weights of a rectangular planar array.

    Ideal continuous phase shifters: element ``(m, n)`` gets the phase
    ``-k (x_m u0 + y_n v0)`` that brings all elements in phase in the steering direction, which
    keeps the weights separable. Quantised phase shifters or channel errors act on
    ``weights.full()`` and are evaluated with the general path of :func:`array_factor`.

    Parameters
    ----------
    steer_az_deg, steer_el_deg : float
        Steering direction (absolute azimuth and elevation), degrees; must be in front of the
        face.
    n_x, n_y : int
        Number of elements along the face horizontal and vertical.
    dx_m, dy_m : float
        Element spacings, metres.
    frequency_hz : float
        Frequency, Hz.
    taylor_sll_db : float
        Taylor design sidelobe level, dB (sign ignored), applied separably in x and y.
    taylor_nbar : int
        Taylor ``nbar``.
    face_azimuth_deg, face_tilt_deg : float, optional
        Orientation of the face (see :func:`face_direction_cosines`).

    Returns
    -------
    SeparableWeights
    """
    u0, v0, w0 = face_direction_cosines(
        steer_az_deg, steer_el_deg, face_azimuth_deg=face_azimuth_deg, face_tilt_deg=face_tilt_deg
    )
    if not w0 > 0.0:
        raise ValueError(
            f"steering direction az={steer_az_deg}, el={steer_el_deg} deg is not in front of "
            f"the face (normal at az={face_azimuth_deg}, tilt={face_tilt_deg} deg)"
        )
    k = 2.0 * np.pi * frequency_hz / SPEED_OF_LIGHT
    x = element_positions(n_x, dx_m)
    y = element_positions(n_y, dy_m)
    return SeparableWeights(
        x=taylor_taper(n_x, taylor_sll_db, taylor_nbar) * np.exp(-1j * k * x * u0),
        y=taylor_taper(n_y, taylor_sll_db, taylor_nbar) * np.exp(-1j * k * y * v0),
    )
