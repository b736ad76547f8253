"""Cubic Hermite lookup tables: the pencil beam's and the array factor's fast interpolation."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def hermite_table(values: NDArray, slopes: NDArray) -> NDArray:
    """Cubic Hermite polynomial coefficients for each interval of a unit-spaced table.

    Parameters
    ----------
    values, slopes : ndarray
        Samples of a function on the grid 0, 1, ..., n - 1 and of its derivative with respect
        to the grid index.

    Returns
    -------
    ndarray
        Shape ``(4, n - 1)``: on interval ``i`` the function is
        ``c[0, i] + t (c[1, i] + t (c[2, i] + t c[3, i]))`` with ``t`` in [0, 1].
    """
    v0, v1, s0, s1 = values[:-1], values[1:], slopes[:-1], slopes[1:]
    # Storing the monomial coefficients once makes each lookup four gathers and a Horner step.
    return np.stack([v0, s0, 3.0 * (v1 - v0) - 2.0 * s0 - s1, 2.0 * (v0 - v1) + s0 + s1])


def hermite_eval(table: NDArray, x: NDArray) -> NDArray:
    """Evaluate a :func:`hermite_table` at fractional grid positions ``x`` in [0, n - 1]."""
    i = np.minimum(x.astype(np.intp), table.shape[1] - 1)
    t = x - i
    c0, c1, c2, c3 = table
    out = c3[i]
    out *= t
    out += c2[i]
    out *= t
    out += c1[i]
    out *= t
    out += c0[i]
    return out
