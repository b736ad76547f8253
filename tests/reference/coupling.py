"""Direct sum over a finite array's S-matrix: the power a steered array radiates.

The reference for the mutual-coupling model of ``blocks/antennas/coupling.py``, written apart
from it: the ``N x N`` S-matrix of an ``n_x`` by ``n_y`` array is built element by element from
the lattice's S-parameters by offset (``S_mn = s(r_n - r_m)``, ``s`` given as a function of
the integer offset), the array is driven with the steered, tapered excitation
``a_n = T_n exp(-j k (x_n u + y_n v))``, each port's active reflection coefficient is
``Gamma_m = sum_n S_mn a_n / a_m`` (e.g. Hansen, *Phased Array Antennas*, ch. 7), and the
fraction of the delivered power that is radiated is

    sum_m |a_m|^2 (1 - |Gamma_m|^2) / sum_m |a_m|^2.

No FFT, no table, no interpolation: a matrix-vector product per steering direction.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def s_matrix(n_x: int, n_y: int, s_of_offset: Callable[[int, int], complex]) -> np.ndarray:
    """The S-matrix of the array, elements numbered ``m = i * n_y + j`` (column i, row j)."""
    cells = [(i, j) for i in range(n_x) for j in range(n_y)]
    s = np.zeros((len(cells), len(cells)), dtype=complex)
    for m, (im, jm) in enumerate(cells):
        for n, (i_n, j_n) in enumerate(cells):
            s[m, n] = s_of_offset(i_n - im, j_n - jm)
    return s


def radiated_fraction(
    s: np.ndarray,
    taper_x: np.ndarray,
    taper_y: np.ndarray,
    *,
    psi_x: float,
    psi_y: float,
) -> float:
    """``sum |a|^2 (1 - |Gamma|^2) / sum |a|^2`` for the steered excitation (psi = k d u)."""
    n_x, n_y = taper_x.size, taper_y.size
    i = np.repeat(np.arange(n_x), n_y)
    j = np.tile(np.arange(n_y), n_x)
    a = np.outer(taper_x, taper_y).ravel() * np.exp(-1j * (i * psi_x + j * psi_y))
    gamma = (s @ a) / a
    power = np.abs(a) ** 2
    return float(np.sum(power * (1.0 - np.abs(gamma) ** 2)) / np.sum(power))
