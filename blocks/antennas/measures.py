"""Pattern measurements on 1-D cuts: half-power beamwidth, first and peak sidelobes."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray


def _check_cut(angles_deg: npt.ArrayLike, power: npt.ArrayLike) -> tuple[NDArray, NDArray]:
    a = np.asarray(angles_deg, dtype=float)
    p = np.asarray(power, dtype=float)
    if a.ndim != 1 or a.shape != p.shape or a.size < 3:
        raise ValueError("angles_deg and power must be 1-D arrays of the same length (>= 3)")
    if np.any(np.diff(a) <= 0):
        raise ValueError("angles_deg must be strictly increasing")
    return a, p


def _parabolic_peak(p: NDArray, i: int) -> float:
    """Peak value of the parabola through samples i-1, i, i+1 (the sample value at the ends)."""
    if i == 0 or i == p.size - 1:
        return float(p[i])
    curvature = p[i + 1] - 2.0 * p[i] + p[i - 1]
    if curvature >= 0:
        return float(p[i])
    return float(p[i] - (p[i + 1] - p[i - 1]) ** 2 / (8.0 * curvature))


def half_power_beamwidth_deg(angles_deg: npt.ArrayLike, power: npt.ArrayLike) -> float:
    """Full width at half maximum of the main lobe of a 1-D power-pattern cut.

    The half-power crossings on either side of the highest sample are located by linear
    interpolation between samples, so the cut should sample the main lobe finely.

    Parameters
    ----------
    angles_deg : array_like
        Strictly increasing angles of the cut, degrees.
    power : array_like
        Power pattern (linear, any normalisation) at those angles.

    Returns
    -------
    float
        Beamwidth, degrees.

    Raises
    ------
    ValueError
        If the pattern does not fall below half power on both sides of its peak.
    """
    a, p = _check_cut(angles_deg, power)
    i0 = int(np.argmax(p))
    half = 0.5 * p[i0]
    right = np.flatnonzero(p[i0:] < half)
    left = np.flatnonzero(p[: i0 + 1] < half)
    if right.size == 0 or left.size == 0:
        raise ValueError("the cut does not reach half power on both sides of the peak")
    j = i0 + right[0]  # first sample below half power, right of the peak
    a_right = np.interp(half, [p[j], p[j - 1]], [a[j], a[j - 1]])
    j = left[-1]  # last sample below half power, left of the peak
    a_left = np.interp(half, [p[j], p[j + 1]], [a[j], a[j + 1]])
    return float(a_right - a_left)


def first_sidelobe_db(angles_deg: npt.ArrayLike, power: npt.ArrayLike) -> float:
    """Level of the higher of the two first sidelobes of a 1-D power-pattern cut.

    From the highest sample the cut is followed outwards on each side to the first null
    (first local minimum) and then to the next local maximum; both maxima are refined by a
    parabola through three samples.

    Parameters
    ----------
    angles_deg : array_like
        Strictly increasing angles of the cut, degrees.
    power : array_like
        Power pattern (linear) at those angles.

    Returns
    -------
    float
        First sidelobe level, dB relative to the main-lobe peak (negative).

    Raises
    ------
    ValueError
        If no sidelobe is found on either side.
    """
    _, p = _check_cut(angles_deg, power)
    peak = _parabolic_peak(p, int(np.argmax(p)))
    lo, hi = main_lobe_bounds(p)
    levels = []
    # From each first null outwards (an end of the cut when there is none).
    for side in (p[hi:], p[lo::-1]):
        falling = np.flatnonzero(np.diff(side) < 0)
        if falling.size == 0:
            continue  # no null, or still rising at the end of the cut: no resolved sidelobe
        levels.append(_parabolic_peak(side, falling[0]))
    if not levels:
        raise ValueError("no sidelobe found in the cut")
    return float(10.0 * np.log10(max(levels) / peak))


def main_lobe_bounds(power: npt.ArrayLike) -> tuple[int, int]:
    """Indices of the first minima (nulls) on either side of the highest sample of a cut.

    Where the cut is monotone to an end, that end is returned.
    """
    p = np.asarray(power, dtype=float)
    i0 = int(np.argmax(p))
    right = np.flatnonzero(np.diff(p[i0:]) > 0)
    left = np.flatnonzero(np.diff(p[i0::-1]) > 0)
    hi = i0 + int(right[0]) if right.size else p.size - 1
    lo = i0 - int(left[0]) if left.size else 0
    return lo, hi


def peak_sidelobe_db(angles_deg: npt.ArrayLike, power: npt.ArrayLike) -> float:
    """Highest level outside the main lobe (beyond the first nulls) of a 1-D power cut.

    Parameters
    ----------
    angles_deg : array_like
        Strictly increasing angles of the cut, degrees.
    power : array_like
        Power pattern (linear) at those angles.

    Returns
    -------
    float
        dB relative to the main-lobe peak (-inf when the cut has no sidelobe).
    """
    _, p = _check_cut(angles_deg, power)
    lo, hi = main_lobe_bounds(p)
    outside = np.concatenate([p[:lo], p[hi + 1 :]])
    if not outside.size or outside.max() <= 0:
        return float("-inf")
    return float(10.0 * np.log10(outside.max() / _parabolic_peak(p, int(np.argmax(p)))))
