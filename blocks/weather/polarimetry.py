"""Two-way polarimetric coupling of an antenna's H and V ports (the model of docs/arrays.md).

A port p excited with complex amplitude t_p radiates the one-way field F_p = (F_ph, F_pv) on
the radar's (h, v) basis; the pattern port carries F_Hh (``co_polar`` H), F_Hv
(``cross_polar`` H), F_Vv (``co_polar`` V) and F_Vh (``cross_polar`` V). A cell with
backscattering matrix S = diag(s_hh, s_vv) (precipitation: no mean canting, LDR neglected)
returns to port q the voltage

    v_q = sum_c F_qc s_cc E_c,     E_c = sum_p F_pc t_p,

so v_q = M_qh s_hh + M_qv s_vv with the two-way coupling M_qc = F_qc E_c. Simultaneous
transmission (SHV) has t = (1, exp(j beta)) (beta: the system's differential phase on
transmit); alternate transmission (AHV) has t = (1, 0) on H pulses and (0, 1) on V pulses.
With no cross-polar field M reduces to diag(F_Hh^2, F_Vv^2 t_V): the squared power pattern
the weather channel uses today.

The expected received covariance of a cell with E|s_hh|^2 = S_h, E|s_vv|^2 = S_v and
E[s_hh* s_vv] = rho sqrt(S_h S_v) exp(j phi_DP) is sum_{c,c'} M_qc M*_q'c' E[s_cc s*_c'c'],
integrated over the cell's solid angle. :func:`uniform_medium` does that for a medium filling
the whole pattern grid, which is what the ZDR bias of an antenna means. The weather channel
does it per truth cell with the helpers below: the received channels of a transmission mode
(:func:`receive_channels`, :func:`port_channels`), their two-way couplings
(:func:`channel_rows`), a cell's channel covariance from per-source weights
(:func:`cell_covariance`) and its Cholesky factor (:func:`cholesky`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

#: Transmission modes.
MODES = ("shv", "ahv")


def port_fields(co: NDArray, cross: NDArray) -> NDArray[np.complex128]:
    """One-way fields F[port, component] from co- and cross-polar patterns (port first).

    ``co`` and ``cross`` have the polarisation (port) axis first; component 0 is h, 1 is v.
    """
    co = np.asarray(co, complex)
    cross = np.asarray(cross, complex)
    return np.stack([np.stack([co[0], cross[0]]), np.stack([cross[1], co[1]])])


def coupling(fields: NDArray, transmit: tuple[complex, complex]) -> NDArray[np.complex128]:
    """Two-way coupling M[q, c] = F[q, c] sum_p F[p, c] t_p for port excitations ``transmit``."""
    t_h, t_v = transmit
    incident = fields[0] * t_h + fields[1] * t_v  # component c of the transmitted field
    return fields * incident[None]


def transmissions(mode: str, transmit_phase_deg: float = 0.0) -> list[tuple[complex, complex]]:
    """Port excitations of one pulse (SHV) or of the H and V pulses (AHV)."""
    if mode == "shv":
        return [(1.0, complex(np.exp(1j * np.deg2rad(transmit_phase_deg))))]
    if mode == "ahv":
        return [(1.0, 0.0), (0.0, 1.0)]
    raise ValueError(f"unknown transmission mode {mode!r}; known: {', '.join(MODES)}")


def scattering_covariance(zdr_db: float, rho: float, phidp_deg: float) -> NDArray:
    """E[s_c s*_c'] for a unit-power H return: [[1, rho e^{-j phi} / sqrt Zdr], ...]."""
    zdr = 10 ** (zdr_db / 10)
    cross = rho * np.exp(1j * np.deg2rad(phidp_deg)) / np.sqrt(zdr)  # E[s_hh* s_vv]
    return np.array([[1.0, np.conj(cross)], [cross, 1.0 / zdr]])


def uniform_medium(
    co: NDArray,
    cross: NDArray,
    d_az_deg: NDArray,
    d_el_deg: NDArray,
    elevation_deg: float,
    *,
    mode: str,
    zdr_db: float,
    rho: float,
    phidp_deg: float,
    transmit_phase_deg: float = 0.0,
) -> dict[str, Any]:
    """Expected polarimetric moments of a uniform medium seen through the antenna.

    ``co``, ``cross``: (polarisation, el, az) patterns of one beam on the offset grid. The
    received covariance is integrated over the grid with cos(el) weights. SHV uses the one
    pulse's H and V voltages; AHV the H port on H pulses and the V port on V pulses (the
    scatterers taken as frozen between the two). Returns the measured ZDR, rho_hv and
    phi_DP and the ZDR bias (measured minus intrinsic), in dB and degrees.
    """
    fields = port_fields(co, cross)
    weight = np.cos(np.deg2rad(elevation_deg + np.asarray(d_el_deg)))[:, None]
    cs = scattering_covariance(zdr_db, rho, phidp_deg)
    pulses = transmissions(mode, transmit_phase_deg)
    m = [coupling(fields, t) for t in pulses]
    # H voltage from the first pulse, V voltage from the last (the same pulse for SHV).
    a, b = m[0][0], m[-1][1]  # (component, el, az): v_H = a . s, v_V = b . s

    def correlate(x: NDArray, y: NDArray) -> complex:
        """E[v_x* v_y] = sum_cc' x_c* y_c' E[s_c* s_c'] integrated over the grid."""
        total = 0.0 + 0.0j
        for c in (0, 1):
            for c2 in (0, 1):
                # E[s_c* s_c2] = conj(E[s_c s_c2*]) = conj(cs[c, c2])
                total += np.sum(np.conj(x[c]) * y[c2] * weight) * np.conj(cs[c, c2])
        return complex(total)

    p_h = correlate(a, a).real
    p_v = correlate(b, b).real
    r_hv = correlate(a, b)
    zdr = 10 * np.log10(p_h / p_v)
    return {
        "zdr_db": float(zdr),
        "zdr_bias_db": float(zdr - zdr_db),
        "rho_hv": float(abs(r_hv) / np.sqrt(p_h * p_v)),
        "phidp_deg": float(np.rad2deg(np.angle(r_hv))),
    }


# ---- what the weather channel needs ------------------------------------------------------------

#: The covariance of (s_hh, s_vv) enters a received covariance through four per-cell sources,
#: in this order: S_h = E|s_hh|^2, S_v = E|s_vv|^2, Y = E[s_hh s_vv*] and X = E[s_hh* s_vv]
#: (= conj Y). Source n pairs the components (c, c') of SOURCE_COMPONENTS[n].
SOURCE_COMPONENTS = ((0, 0), (1, 1), (0, 1), (1, 0))
#: Sources as they are under conjugation (S_h, S_v stay; Y and X swap).
CONJUGATE_SOURCES = (0, 1, 3, 2)


def receive_channels(mode: str, need_v: bool) -> list[tuple[int, int]]:
    """The received channels a weather channel draws, as (transmit state, port) pairs.

    SHV has one transmit state and two channels (the H and V ports). AHV has two states (H
    pulses, then V pulses) and four channels, co-polar first: H port on H pulses, V port on V
    pulses, V port on H pulses, H port on V pulses. ``need_v`` False keeps the H co-polar
    channel only.
    """
    if mode not in MODES:
        raise ValueError(f"unknown transmission mode {mode!r}; known: {', '.join(MODES)}")
    chans = [(0, 0), (0, 1)] if mode == "shv" else [(0, 0), (1, 1), (0, 1), (1, 0)]
    return chans if need_v else chans[:1]


def port_channels(mode: str) -> tuple[tuple[int, int], tuple[int, int]]:
    """For each port (H, V): the channel it records on even and on odd pulses.

    AHV transmits H on even pulses and V on odd ones; both ports receive every pulse.
    """
    return ((0, 0), (1, 1)) if mode == "shv" else ((0, 3), (2, 1))


def channel_rows(
    co: NDArray, cross: NDArray, mode: str, transmit_phase_deg: float, channels: list
) -> NDArray[np.complex128]:
    """Two-way couplings a_k[c] = M_t(k)[port(k), c] of each channel: (channel, component, ...).

    The channel's voltage from a direction is sum_c a_k[c] s_c (:func:`coupling`). Computed
    in the patterns' own precision (complex64 from the pattern port).
    """
    dtype = np.result_type(co.dtype, cross.dtype, np.complex64)
    fields = ((co[0], cross[0]), (cross[1], co[1]))  # F[port][component]
    incident = [
        [fields[0][c] * dtype.type(t_h) + fields[1][c] * dtype.type(t_v) for c in (0, 1)]
        for t_h, t_v in transmissions(mode, transmit_phase_deg)
    ]
    out = np.empty((len(channels), 2, *co.shape[1:]), dtype)
    for k, (state, port) in enumerate(channels):
        for c in (0, 1):
            np.multiply(fields[port][c], incident[state][c], out=out[k, c])
    return out


def pairs(n: int) -> list[tuple[int, int]]:
    """Channel pairs (k, k') with k <= k', diagonal first: the order of stored covariances."""
    return [(k, k) for k in range(n)] + [(k, q) for k in range(n) for q in range(k + 1, n)]


def cell_covariance(weights: NDArray, sources: Sequence[NDArray]) -> NDArray[np.complex128]:
    """E[w_k w_k'*] per pair from per-pair source weights (pair, source, cell) and the sources.

    ``sources`` are (S_h, S_v, Y, X) per cell (see :data:`SOURCE_COMPONENTS`).
    """
    return sum(weights[:, s] * sources[s][None] for s in range(4))


def cholesky(cov: NDArray, n: int, floor: float) -> NDArray:
    """Lower Cholesky factors L of n x n Hermitian covariances, L L^H = P, vectorised.

    ``cov`` holds E[w_k w_k'*] per pair in :func:`pairs` order (pair, ...). A positive
    semi-definite P of rank below n (a channel fully determined by earlier ones, e.g. a
    cross-polar channel proportional to a co-polar one) has a residual of round-off only: a
    residual variance below ``floor`` times the channel's own is taken as zero, and so is the
    column it would divide. Returns L (k, i, ...) with zeros above the diagonal.
    """
    index = {p: i for i, p in enumerate(pairs(n))}
    out = np.zeros((n, n, *cov.shape[1:]), cov.dtype)
    for k in range(n):
        own = cov[index[(k, k)]].real
        for i in range(k + 1):
            # P[k, i] = E[w_k w_i*] = conj of the stored (i, k) pair
            s = cov[index[(k, k)]] if i == k else np.conj(cov[index[(i, k)]])
            s = s - np.sum(out[k, :i] * np.conj(out[i, :i]), axis=0) if i else s.copy()
            if i == k:
                d = s.real
                out[k, k] = np.sqrt(np.where(d > floor * own, d, 0.0))
            else:
                pivot = out[i, i].real
                safe = np.where(pivot > 0, pivot, 1.0)
                out[k, i] = np.where(pivot > 0, s / safe, 0.0)
    return out
