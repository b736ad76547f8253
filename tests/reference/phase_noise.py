"""Independent prediction of what oscillator phase noise does to a zero-velocity point target.

Written apart from ``blocks/receivers/phase_noise.py``. The echo of pulse m from delay tau is
exp(j D_m), D_m = phi(m T) - phi(m T + tau), phi stationary Gaussian with one-sided spectrum
S(f) = 2 x 10^(L / 10) rad^2/Hz. D is Gaussian with autocovariance across pulses

    C_k = int_0^F 4 S(f) sin^2(pi f tau) cos(2 pi f k T) df,

so E[x_m x_n^*] = exp(-(C_0 - C_|m-n|)). For a flat L up to F the integral is closed form:
with I(a) = int_0^F cos(2 pi a f) df = sin(2 pi a F) / (2 pi a) (F at a = 0),
C_k = 2 S [ I(k T) - I(k T + tau) / 2 - I(k T - tau) / 2 ].

The residual of the dwell after removing its mean (what a zero-velocity clutter filter leaves,
as a fraction of the target's power) is 1 - (1 / M^2) sum_{m,n} exp(-(C_0 - C_|m-n|)); its
inverse is the clutter suppression the phase noise allows.
"""

from __future__ import annotations

import numpy as np


def _i(a: np.ndarray, top_hz: float) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    safe = np.where(a == 0, 1.0, a)
    return np.where(a == 0, top_hz, np.sin(2 * np.pi * safe * top_hz) / (2 * np.pi * safe))


def flat_covariance(level_dbc: float, top_hz: float, tau_s: float, prt_s: float, lags: int):
    """C_k, k = 0..lags-1, for a flat profile L = level_dbc up to top_hz."""
    s = 2 * 10 ** (level_dbc / 10)
    k = np.arange(lags) * prt_s
    return 2 * s * (_i(k, top_hz) - _i(k + tau_s, top_hz) / 2 - _i(k - tau_s, top_hz) / 2)


def residual_fraction(cov: np.ndarray) -> float:
    """1 - (1/M^2) sum_{m,n} exp(-(C_0 - C_|m-n|)): the dwell's power left after its mean."""
    m = cov.size
    lag = np.abs(np.subtract.outer(np.arange(m), np.arange(m)))
    return float(1 - np.exp(-(cov[0] - cov[lag])).sum() / m**2)
