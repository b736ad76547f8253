"""Independent computations of a radiated pulse's spectrum and its -40 dB bandwidth.

Written apart from ``blocks/transmitters/emission.py`` (no code shared): the spectrum is the
discrete-time Fourier transform summed directly at any frequency (no FFT, no zero padding),
and the outermost -40 dB crossings are found by scanning a grid from the band edges inwards
and refining the first crossing with Brent's method on the DTFT itself. The trapezoidal pulse
also has its closed-form continuous spectrum, and the Taylor LFM through the Saleh amplifier is
built here from its definition (scipy's Taylor window, the paper's equations 3 and 4).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq


def dtft_db(x: np.ndarray, fs: float, f: np.ndarray) -> np.ndarray:
    """|sum_k x_k exp(-j 2 pi f k / fs)|^2 in dB (not normalised), at frequencies ``f``."""
    k = np.arange(x.size)
    out = np.empty(np.size(f))
    flat = np.atleast_1d(f)
    for a in range(0, flat.size, 512):
        ph = np.exp(-2j * np.pi * np.outer(flat[a : a + 512], k) / fs)
        out[a : a + 512] = np.abs(ph @ x) ** 2
    return 10 * np.log10(np.maximum(out, 1e-300))


def bandwidth_40_dtft(x: np.ndarray, fs: float, level_db: float = -40.0) -> float:
    """Outermost ``level_db`` crossings of the DTFT relative to its peak; their distance (Hz).

    The peak is the maximum over a grid 8 times finer than 1 / pulse length, refined by
    a parabola; the crossings are scanned on that grid from +-fs/2 inwards.
    """
    x = np.asarray(x, dtype=complex)
    step = fs / x.size / 8
    f = np.arange(-fs / 2, fs / 2, step)
    level = dtft_db(x, fs, f)
    peak = level.max()

    def rel(v: float) -> float:
        return float(dtft_db(x, fs, np.array([v]))[0] - peak - level_db)

    above = np.flatnonzero(level - peak >= level_db)
    lo, hi = above[0], above[-1]
    low = brentq(rel, f[lo - 1], f[lo])
    high = brentq(rel, f[hi], f[hi + 1])
    return float(high - low)


def trapezoid_bandwidth_40(width_s: float, ramp_s: float, level_db: float = -40.0) -> float:
    """-40 dB bandwidth of a continuous trapezoid (closed form), ``ramp_s`` edges inside
    ``width_s``: the convolution of a rectangle of width - ramp with one of ramp, so
    |X(f)|^2 proportional to sinc^2(f (width - ramp)) sinc^2(f ramp)."""
    top = width_s - ramp_s

    def rel(f: float) -> float:
        v = (np.sinc(f * top) * np.sinc(f * ramp_s)) ** 2
        return float(10 * np.log10(max(v, 1e-300)) - level_db)

    # Scan downwards from well beyond the crossing, on a grid fine against 1 / width.
    f = np.arange(20.0 / np.sqrt(top * ramp_s), 0, -1 / (8 * width_s))
    vals = np.array([rel(v) for v in f])
    i = int(np.argmax(vals >= 0))
    return 2 * float(brentq(rel, f[i], f[i - 1]))


def taylor_lfm_through_saleh(
    bandwidth_hz: float, width_s: float, fs: float, sll_db: float = 60.0, nbar: int = 10
) -> np.ndarray:
    """A Taylor-windowed LFM driven to saturation through the paper's Saleh amplifier."""
    import scipy.signal.windows as windows

    n = round(width_s * fs)
    t = (np.arange(n) - (n - 1) / 2) / fs
    x = np.exp(1j * np.pi * bandwidth_hz / (n / fs) * t**2) * windows.taylor(
        n, nbar=nbar, sll=sll_db, norm=True
    )
    x = x / np.abs(x).max()
    alpha_a, beta_a, alpha_phi, beta_phi = 2.1587, 1.1517, 4.0033, 9.1040
    r = np.abs(x) / np.sqrt(beta_a)
    amp = alpha_a * r / (1 + beta_a * r**2)
    phase = alpha_phi * r**2 / (1 + beta_phi * r**2)
    return amp * np.exp(1j * (np.angle(x) + phase))
