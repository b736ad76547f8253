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
the whole pattern grid, which is what the ZDR bias of an antenna means.
"""

from __future__ import annotations

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
