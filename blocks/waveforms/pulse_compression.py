"""Pulse-compression figures of merit, from a receive filter's range response.

Used by ``pasim waveform``, the NLFM design script and the tests. The filter output y(offset)
is sampled at the waveform's rate; sidelobe peaks fall between samples, so y is first
interpolated (band-limited, by FFT) ``upsample`` times.
"""

from __future__ import annotations

from typing import Any

import numpy as np

# Below this many multiply-adds scipy.signal.convolve always convolves directly, through
# np.convolve (its cost model for 1-D "full" picks the FFT only above about 4.7e6 products):
# calling np.convolve there gives the same numbers without importing scipy.signal (about
# 0.4 s of every run's start-up). Checked against scipy in tests/waveforms/test_waveforms.py.
DIRECT_PRODUCTS = 4_000_000


def convolve_full(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The full 1-D convolution of ``a`` and ``b``, as ``scipy.signal.convolve`` gives it."""
    if a.size * b.size <= DIRECT_PRODUCTS:
        return np.convolve(a, b, mode="full")
    import scipy.signal

    return scipy.signal.convolve(a, b, mode="full")


def interpolate(y: np.ndarray, dx: float, upsample: int) -> tuple[np.ndarray, float]:
    """Band-limited interpolation of a finite sequence (zero-padded so nothing wraps)."""
    import scipy.signal

    pad = y.size
    padded = np.concatenate([np.zeros(pad, y.dtype), y, np.zeros(pad, y.dtype)])
    fine = scipy.signal.resample(padded, padded.size * upsample)
    start = pad * upsample
    return fine[start : start + (y.size - 1) * upsample + 1], dx / upsample


def mainlobe(power: np.ndarray) -> tuple[int, int, int]:
    """Peak index and the first minima on each side, searched beyond the -6 dB points.

    Starting from the -6 dB points makes a ripple on top of a distorted mainlobe count as
    mainlobe, not as a null.
    """
    i = int(np.argmax(power))
    quarter = power[i] / 4
    lo = i
    while lo > 0 and power[lo] > quarter:
        lo -= 1
    while lo > 0 and power[lo - 1] < power[lo]:
        lo -= 1
    hi = i
    while hi < power.size - 1 and power[hi] > quarter:
        hi += 1
    while hi < power.size - 1 and power[hi + 1] < power[hi]:
        hi += 1
    return i, lo, hi


def half_power_width(power: np.ndarray, dx: float) -> float:
    """Width of the mainlobe where the power is above a quarter of the peak (-6 dB).

    -6 dB in power is half the voltage: c tau / 2 for a rectangular pulse, 1.21 c / (2 B)
    for an LFM.
    """
    i = int(np.argmax(power))
    level = power[i] / 4
    lo = i
    while lo > 0 and power[lo - 1] > level:
        lo -= 1
    hi = i
    while hi < power.size - 1 and power[hi + 1] > level:
        hi += 1
    # Linear interpolation of the two crossings.
    left = lo - (power[lo] - level) / (power[lo] - power[lo - 1]) if lo > 0 else float(lo)
    right = (
        hi + (power[hi] - level) / (power[hi] - power[hi + 1]) if hi < power.size - 1 else float(hi)
    )
    return float((right - left) * dx)


def sidelobes(voltage: np.ndarray, dx: float, upsample: int = 8) -> dict[str, Any]:
    """Peak and integrated sidelobe levels and the -6 dB width of a filter output.

    Parameters
    ----------
    voltage : complex array
        Filter output for a point target, evenly sampled.
    dx : float
        Sample spacing (metres of range offset, or seconds).
    upsample : int
        Interpolation factor before the search.

    Returns
    -------
    dict
        ``psl_db`` (largest sidelobe over the peak, outside the first minima),
        ``isl_db`` (sidelobe energy over mainlobe energy), ``resolution`` (-6 dB width, units
        of ``dx``), ``peak`` (peak |y|^2), ``peak_index`` and ``psl_index`` (in the original
        samples, fractional).
    """
    fine, step = interpolate(np.asarray(voltage, complex), dx, upsample)
    power = np.abs(fine) ** 2
    i, lo, hi = mainlobe(power)
    side = power.copy()
    side[lo : hi + 1] = 0.0
    if side.max() <= 0:
        psl, isl, j = -np.inf, -np.inf, i
    else:
        j = int(np.argmax(side))
        psl = 10 * np.log10(side[j] / power[i])
        isl = 10 * np.log10(side.sum() / power[lo : hi + 1].sum())
    return {
        "psl_db": float(psl),
        "isl_db": float(isl),
        "resolution": half_power_width(power, step),
        "peak": float(power[i]),
        "peak_index": i / upsample,
        "psl_index": j / upsample,
    }


def power_efficiency(envelope: np.ndarray, peak: float | None = None) -> float:
    """Energy over that of a constant envelope of the same length at peak amplitude ``peak``
    (the envelope's own peak by default)."""
    a2 = np.abs(np.asarray(envelope)) ** 2
    ref = float(a2.max()) if peak is None else peak**2
    return float(a2.mean() / ref)


def snr_loss_db(pulse: np.ndarray, taps: np.ndarray) -> float:
    """Loss of peak SNR of the filter ``taps`` against the filter matched to ``pulse``.

    -10 log10(max |s * h|^2 / (E_s sum|h|^2)), the largest output over all lags: 0 for the
    matched filter (Cauchy-Schwarz), positive otherwise (rounding below 0 is returned as 0).
    """
    y = convolve_full(pulse, taps)
    e_s = float(np.sum(np.abs(pulse) ** 2))
    gain = float(np.max(np.abs(y) ** 2)) / (e_s * float(np.sum(np.abs(taps) ** 2)))
    loss = float(-10 * np.log10(gain))
    return loss if loss > 0 else 0.0
