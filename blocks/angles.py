"""Angles on the circle, shared by the blocks that compare azimuths, phases and velocities."""

from __future__ import annotations

import numpy as np


def circular_difference(a: np.ndarray, b: np.ndarray, period: np.ndarray | float) -> np.ndarray:
    """a - b wrapped into [-period/2, period/2)."""
    return (a - b + period / 2) % period - period / 2


def nearest_radial(azimuth_deg: np.ndarray, radials_deg: np.ndarray) -> np.ndarray:
    """Index of the radial nearest each azimuth, measured on the circle."""
    d = circular_difference(radials_deg[None, :], np.asarray(azimuth_deg)[:, None], 360.0)
    return np.argmin(np.abs(d), axis=1)
