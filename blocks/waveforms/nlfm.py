"""Nonlinear FM design: the stationary-phase principle, and an optimised frequency law.

By the principle of stationary phase, the energy a pulse spends at instantaneous frequency f
is the energy its spectrum holds at f. With envelope a(t) and spectral density G(f) both
normalised to unit energy, the frequency law f(t) maps the cumulative envelope energy onto the
cumulative spectral density,

    int_0^t a(u)^2 du / E = int_{-B/2}^{f(t)} G(v) dv,

and the phase is 2 pi times the integral of f(t). A constant envelope (a = 1) gives the
classical design (group delay proportional to the cumulative density). Densities here are
functions of the normalised frequency x = f / B on [-1/2, 1/2], given by their logarithm:
a Gaussian of standard deviation sigma is ``-x^2 / (2 sigma^2)``; the optimised design uses a
cubic spline through a few knots of |x| (a Gaussian corrected where it helps).

:func:`design_optimised` searches the spline knots and the edge taper for the lowest peak
sidelobe outside a fixed mainlobe (differential evolution, then Nelder-Mead); it takes
minutes, so its result ships as ``data/nlfm_optimised.json`` and the waveform block only
reads it. ``benchmarks/design_nlfm.py`` re-runs the search and rewrites the file.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

#: The shipped optimised design (written by benchmarks/design_nlfm.py).
OPTIMISED_FILE = Path(__file__).parent.parent / "data" / "nlfm_optimised.json"

# Fine grids of the design: the phase is integrated on SUBSAMPLE points per output sample and
# the cumulative density tabulated on DENSITY_POINTS frequencies (both converge far below the
# sidelobe levels of interest: doubling either moves the -70 dB design by < 0.1 dB).
SUBSAMPLE = 16
DENSITY_POINTS = 8001

LogDensity = Callable[[np.ndarray], np.ndarray]


def tukey_taper(u: np.ndarray, fraction: float) -> np.ndarray:
    """Tukey (cosine-edged) amplitude at normalised times u in [0, 1].

    ``fraction`` is the part of the pulse in the two cosine edges together (scipy's
    ``alpha``); written here for arbitrary u, where scipy.signal.windows.tukey gives only
    equally spaced samples. Its power efficiency is 1 - 5 fraction / 8.
    """
    u = np.asarray(u, dtype=float)
    if fraction <= 0:
        return np.ones_like(u)
    half = fraction / 2
    edge = np.minimum(u, 1.0 - u)
    return np.where(edge < half, 0.5 * (1 - np.cos(np.pi * np.clip(edge, 0, None) / half)), 1.0)


def gaussian_log_density(std_fraction: float) -> LogDensity:
    """log G(x) of a Gaussian density with standard deviation ``std_fraction`` x bandwidth."""
    return lambda x: -(x**2) / (2.0 * std_fraction**2)


def spline_log_density(knots: np.ndarray, values: np.ndarray) -> LogDensity:
    """log G(x) as a cubic spline of |x| through (knots, values), flat at x = 0 (even G)."""
    from scipy.interpolate import CubicSpline

    spline = CubicSpline(knots, values, bc_type=((1, 0.0), "not-a-knot"))
    return lambda x: spline(np.abs(x))


def stationary_phase(
    bandwidth_hz: float,
    width_s: float,
    sample_rate_hz: float,
    log_density: LogDensity,
    taper_fraction: float = 0.0,
) -> np.ndarray:
    """Complex envelope (peak amplitude 1) of the NLFM whose energy maps onto the density.

    Samples sit at the centres of ``round(width x rate)`` intervals spanning the pulse.
    """
    from scipy.integrate import cumulative_trapezoid

    n = max(2, round(width_s * sample_rate_hz))
    t = np.linspace(0.0, width_s, n * SUBSAMPLE + 1)
    amp = tukey_taper(t / width_s, taper_fraction)
    energy = cumulative_trapezoid(amp**2, t, initial=0.0)
    energy /= energy[-1]
    x = np.linspace(-0.5, 0.5, DENSITY_POINTS)
    log_g = log_density(x)
    density = np.exp(log_g - np.max(log_g))
    cum = cumulative_trapezoid(density, x, initial=0.0)
    cum /= cum[-1]
    freq = np.interp(energy, cum, x) * bandwidth_hz
    phase = 2 * np.pi * cumulative_trapezoid(freq, t, initial=0.0)
    ts = (np.arange(n) + 0.5) / sample_rate_hz
    env = np.interp(ts, t, amp) * np.exp(1j * np.interp(ts, t, phase))
    return env / np.max(np.abs(env))


def load_optimised(path: Path = OPTIMISED_FILE) -> dict[str, Any]:
    """The shipped optimised design (knots, log-density values, taper and what it achieved)."""
    with open(path, encoding="utf-8") as fh:
        design = json.load(fh)
    for key in ("knots", "log_density", "taper_fraction"):
        if key not in design:
            raise ValueError(f"{path}: the NLFM design has no {key!r}")
    return design


def optimised_envelope(
    design: dict[str, Any],
    bandwidth_hz: float,
    width_s: float,
    sample_rate_hz: float,
    taper_fraction: float | None = None,
) -> np.ndarray:
    """The optimised NLFM of ``design`` (see :func:`load_optimised`), sampled."""
    taper = design["taper_fraction"] if taper_fraction is None else taper_fraction
    log_density = spline_log_density(np.asarray(design["knots"]), np.asarray(design["log_density"]))
    return stationary_phase(bandwidth_hz, width_s, sample_rate_hz, log_density, taper)


def peak_sidelobe_beyond(
    envelope: np.ndarray, sample_rate_hz: float, exclusion_s: float, upsample: int = 4
) -> float:
    """Peak sidelobe (dB) of the matched-filter output at lags beyond +-``exclusion_s``.

    The autocorrelation is computed from |S(f)|^2 by FFT and interpolated ``upsample`` times
    (band-limited interpolation) so that sidelobe peaks between samples are seen. A fixed
    exclusion, rather than the first null, keeps an optimiser from widening the mainlobe to
    swallow the sidelobes.
    """
    import scipy.fft

    n_fft = scipy.fft.next_fast_len(2 * envelope.size)
    power = np.abs(scipy.fft.fft(envelope, n_fft)) ** 2
    padded = np.zeros(n_fft * upsample)
    half = n_fft // 2
    padded[:half] = power[:half]
    padded[-half:] = power[-half:]
    acf = np.abs(scipy.fft.ifft(padded))[: n_fft * upsample // 2]
    lag_s = np.arange(acf.size) / (sample_rate_hz * upsample)
    side = acf[lag_s >= exclusion_s]
    return float(20 * np.log10(side.max() / acf[0]))


def design_optimised(
    time_bandwidth: float = 180.0,
    oversampling: float = 2.0,
    knots: int = 6,
    max_taper_fraction: float = 0.2,
    exclusion_over_bandwidth: float = 5.0,
    seeds: tuple[int, ...] = (1, 2, 3),
    maxiter: int = 400,
    popsize: int = 25,
    upsample: int = 8,
) -> dict[str, Any]:
    """Search the log-density knots and Tukey taper for the lowest peak sidelobe.

    The pulse is designed at unit bandwidth (time in units of 1/B): the spline knots sit
    evenly on |x| in [0, 1/2] with the value at 0 fixed to 0, and the taper fraction is at
    most ``max_taper_fraction`` (a Tukey taper of fraction a has power efficiency
    1 - 5 a / 8: 0.875 at 0.2). The cost is :func:`peak_sidelobe_beyond` with the mainlobe
    excluded to ``exclusion_over_bandwidth / B``, on an autocorrelation interpolated
    ``upsample`` times (coarser grids let the search hide a sidelobe between samples).
    Differential evolution from each seed, then Nelder-Mead; the best is returned with what
    it achieves. Deterministic for given arguments; takes minutes.
    """
    from scipy.optimize import differential_evolution, minimize

    bandwidth, width = 1.0, float(time_bandwidth)
    rate = oversampling * bandwidth
    grid = np.linspace(0.0, 0.5, knots)
    exclusion = exclusion_over_bandwidth / bandwidth

    def envelope(z: np.ndarray) -> np.ndarray:
        log_density = spline_log_density(grid, np.concatenate([[0.0], z[1:]]))
        return stationary_phase(bandwidth, width, rate, log_density, float(z[0]))

    def cost(z: np.ndarray) -> float:
        return peak_sidelobe_beyond(envelope(z), rate, exclusion, upsample)

    bounds = [(0.0, max_taper_fraction)] + [(-14.0, 2.0)] * (knots - 1)
    best: tuple[float, np.ndarray] | None = None
    for seed in seeds:
        res = differential_evolution(
            cost, bounds, seed=seed, maxiter=maxiter, popsize=popsize, tol=1e-12, polish=False
        )
        res = minimize(cost, res.x, method="Nelder-Mead", options={"maxiter": 6000, "xatol": 1e-7})
        z = np.asarray(res.x)
        z[0] = float(np.clip(z[0], 0.0, max_taper_fraction))  # Nelder-Mead is unbounded
        value = cost(z)
        if best is None or value < best[0]:
            best = (value, z)
    assert best is not None
    z = best[1]
    env = envelope(z)
    return {
        "knots": grid.tolist(),
        "log_density": [0.0, *(float(v) for v in z[1:])],
        "taper_fraction": float(z[0]),
        "time_bandwidth": float(time_bandwidth),
        "oversampling": float(oversampling),
        "exclusion_over_bandwidth": float(exclusion_over_bandwidth),
        "max_taper_fraction": float(max_taper_fraction),
        "upsample": int(upsample),
        "peak_sidelobe_db": peak_sidelobe_beyond(env, rate, exclusion, upsample=16),
        "power_efficiency": float(np.mean(np.abs(env) ** 2)),
    }
