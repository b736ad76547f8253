"""Pulse timing of a dwell: uniform or staggered PRT, and transmit phase codes.

Read from the scan's beams (:data:`pasim_blocks.signals.BEAMS`): ``prt`` is the (first) PRT
T1; a staggered scan adds ``prt_ratio`` = T1 / T2 (2/3 or 3/4), its pulses alternating T1, T2,
T1, ... apart; a phase-coded scan adds ``transmit_phase``, each pulse's transmit phase (rad),
and, when its transmitter is not ideal, ``transmit_phase_error`` and ``transmit_amplitude``.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import xarray as xr

#: Staggered-PRT ratios T1 / T2 a scan may use.
STAGGERS = {"2/3": Fraction(2, 3), "3/4": Fraction(3, 4)}


def prt_ratio(beams: xr.Dataset) -> Fraction | None:
    """T1 / T2 of a staggered scan (a small fraction), None for a uniform PRT."""
    if "prt_ratio" not in beams:
        return None
    r = float(np.asarray(beams["prt_ratio"].values).ravel()[0])
    return Fraction(r).limit_denominator(16)


def pulse_times(prt_s: float, pulses: int, ratio: Fraction | None = None) -> np.ndarray:
    """Times of the dwell's pulses from the first (s): m T, or alternating T1, T2 steps."""
    if ratio is None:
        return np.arange(pulses) * prt_s
    steps = np.where(np.arange(pulses - 1) % 2 == 0, prt_s, prt_s / float(ratio))
    return np.concatenate([[0.0], np.cumsum(steps)])


def fine_grid(prt_s: float, pulses: int, ratio: Fraction | None) -> tuple[float, np.ndarray]:
    """A uniform step u and the index of each pulse on it: T1 = a u, T2 = b u for a ratio
    a / b (u = T1 for a uniform PRT, every index)."""
    if ratio is None:
        return prt_s, np.arange(pulses)
    u = prt_s / ratio.numerator
    idx = np.rint(pulse_times(prt_s, pulses, ratio) / u).astype(np.int64)
    return u, idx


def transmit_phase(beams: xr.Dataset, pulses: int) -> np.ndarray | None:
    """Transmit phase (rad) of each pulse of each beam (beam x pulse), None without a code."""
    if "transmit_phase" not in beams:
        return None
    return np.asarray(beams["transmit_phase"].values, np.float64).reshape(-1, pulses)


def code_errors(beams: xr.Dataset, pulses: int) -> tuple[np.ndarray, np.ndarray] | None:
    """What the transmitter adds to a phase code (beam x pulse each): the phase error (rad)
    and the voltage amplitude over the nominal of each pulse; None for an ideal code. The
    echoes carry them; a receiver decodes with :func:`transmit_phase` alone."""
    if "transmit_phase_error" not in beams:
        return None
    phase = np.asarray(beams["transmit_phase_error"].values, np.float64).reshape(-1, pulses)
    amplitude = np.asarray(beams["transmit_amplitude"].values, np.float64).reshape(-1, pulses)
    return phase, amplitude


def draw_code_errors(
    gen: np.random.Generator, pulses: int, phase_deg: float, ripple_db: float
) -> tuple[np.ndarray, np.ndarray]:
    """Independent errors of ``pulses`` coded pulses: phase N(0, ``phase_deg``^2) (returned
    in rad) and amplitude 10^(a / 20) with a ~ N(0, ``ripple_db``^2)."""
    z = gen.standard_normal((2, pulses))
    return np.deg2rad(phase_deg) * z[0], 10 ** (ripple_db * z[1] / 20)


def cohere_first_trip(iq: np.ndarray, beams: xr.Dataset) -> np.ndarray:
    """The received I/Q (beam x gate x pulse x channel) cohered to the first trip: each pulse
    multiplied by e^(-j psi_m), the conjugate of its transmit phase (SZ-1 / SZ-2's first
    step), so a first-trip echo is the uncoded one and the other trips stay modulated. The
    I/Q itself (not a copy) without a phase code or without pulses."""
    pulses = iq.shape[2]
    psi = transmit_phase(beams, pulses) if pulses else None
    if psi is None:
        return iq
    if psi.shape[0] != iq.shape[0]:
        raise ValueError(
            f"the scan's transmit phases are for {psi.shape[0]} beams, the I/Q has {iq.shape[0]}"
        )
    return iq * np.exp(-1j * psi).astype(iq.dtype)[:, None, :, None]


def sz_code(n: int, m: int) -> np.ndarray:
    """Transmit phases (rad) of the SZ(n/M) code (Sachidananda and Zrnic 1999):
    psi_k = sum_(l<=k) n pi l^2 / M. After cohering to one trip, the next trip carries the
    switching code exp(-j n pi k^2 / M), which has period M / n in k and a spectrum of n equal
    lines M/n bins apart: its power is spread into n replicas. With n = 8, M = 64 the phases
    repeat every 64 pulses."""
    k = np.arange(m)
    return np.mod(np.cumsum(n * np.pi * k**2 / m), 2 * np.pi)


def trip_phase(psi: np.ndarray, trip: int) -> np.ndarray:
    """Phase a trip-``trip`` echo carries on each pulse (trip 1: the pulse's own transmit
    phase; trip k: that of k - 1 pulses earlier; the code is taken as periodic in the dwell,
    the dwell being one period of the continuous transmission)."""
    return np.roll(psi, trip - 1, axis=-1)
