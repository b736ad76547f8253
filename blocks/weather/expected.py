"""The ``expected`` fidelity level: the echo's expected correlations through the beam and the
range response, with no random draw.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..signals import (
    CORRELATION_PRODUCTS,
    SHV_PRODUCTS,
)

# Moments used for a cell that has reflectivity but lacks another field (e.g. beyond the
# Doppler cut's range): a still, narrow-spectrum, well-correlated echo.
from .beams import Coupling
from .cells import TruthCells
from .polarimetry import (
    CONJUGATE_SOURCES,
)


def expected_correlations(
    cells: TruthCells, near: np.ndarray, omega: np.ndarray, terms: int, alternate: bool
) -> Any:
    """Expected correlations per padded truth gate, before range weighting: gate x term x
    product (:data:`pasim_blocks.signals.CORRELATION_PRODUCTS`; the lag-2 and lag-1 H-V
    products only if ``alternate``, AHV, whose processor alone reads them).

    Term n carries each cell's contribution times u^n (its normalised velocity), so the
    range response's power r_d(u) = Σ_n power[n, d] u^n weighs every cell at its own
    velocity (range-Doppler coupling).
    """
    out = np.empty((cells.s_h.shape[1], terms, len(CORRELATION_PRODUCTS)), np.complex128)
    sq = np.sqrt(omega[0] * omega[1])
    u = cells.u[near]
    for n in range(terms):
        un = u**n if n else 1.0
        out[:, n, 0] = omega[0] @ (cells.s_h[near] * un)
        out[:, n, 1] = omega[1] @ (cells.s_v[near] * un)
        out[:, n, 2] = omega[0] @ (cells.r1_h[near] * un)
        out[:, n, 3] = omega[1] @ (cells.r1_v[near] * un)
        out[:, n, 4] = sq @ (cells.cross[near] * un)
    out[:, :, len(SHV_PRODUCTS) :] = 0.0
    if not alternate:
        return out
    lag1, lag2 = cells.lags(near)
    for n in range(terms):
        un = u**n if n else 1.0
        out[:, n, 5] = omega[0] @ (cells.s_h[near] * lag2 * un)
        out[:, n, 6] = omega[1] @ (cells.s_v[near] * lag2 * un)
        x1 = cells.cross[near] * lag1 * un
        out[:, n, 7] = sq @ x1
        out[:, n, 8] = sq @ (np.conj(cells.cross[near]) * lag1 * un)
    return out


def expected_correlations_coupled(
    cells: TruthCells, near: np.ndarray, coupling: Coupling, terms: int, alternate: bool
) -> Any:
    """:meth:`expected_correlations` through the coupling of the co-polar channels h and v.

    Each cell's E[w_k w_k'*] is sum_n weights[k, k', n] src_n (:class:`Coupling`); a lag l
    multiplies it by the cell's r(l): R_l(h) = sum P_hh r(l), R1_HV = E[h_m* v_m+1] =
    sum conj(P_hv) r(1), R1_VH = E[v_m* h_m+1] = sum P_hv r(1).
    """
    w = coupling.select(2)  # pairs (h, h), (v, v), (h, v)
    # conj(P_hv) = sum_n conj(w_hv[n]) conj(src_n): conjugation swaps sources Y and X.
    w_hv_conj = np.conj(w[2][list(CONJUGATE_SOURCES)])
    n_j, n_g = near.size, cells.s_h.shape[1]
    # Only the gates some near radial has echo at.
    gates = np.flatnonzero(cells.echo[near].any(axis=0))
    src = np.empty((4, n_j, gates.size), np.complex128)  # source x radial x gate
    for k, a in enumerate(cells.sources(near[:, None], gates[None, :])):
        src[k] = a
    lag1, lag2 = (lag[:, gates] for lag in cells.lags(near))
    u = cells.u[near][:, gates]
    # Products by lag: lag 0 -> R0_H, R0_V, R0_HV; lag 1 -> R1_H, R1_V, R1_HV, R1_VH; lag
    # 2 -> R2_H, R2_V. One matrix product each over (source, radial).
    plan: tuple[tuple[Any, np.ndarray, tuple[int, ...]], ...] = (
        (None, np.stack([w[0], w[1], w_hv_conj]), (0, 1, 4)),
        (lag1, np.stack([w[0], w[1], w_hv_conj, w[2]]), (2, 3, 7, 8)),
        (lag2, np.stack([w[0], w[1]]), (5, 6)),
    )
    if not alternate:
        plan = (plan[0], (lag1, np.stack([w[0], w[1]]), (2, 3)))
    out = np.zeros((n_g, terms, len(CORRELATION_PRODUCTS)), np.complex128)
    for n in range(terms):
        s0 = src * u**n if n else src
        for lag, weights, index in plan:
            s = s0 if lag is None else s0 * lag
            out[np.ix_(gates, np.array([n]), np.array(index))] = (
                weights.reshape(len(index), 4 * n_j) @ s.reshape(4 * n_j, gates.size)
            ).T[:, None, :]
    out[:, :, :2] = out[:, :, :2].real
    return out
