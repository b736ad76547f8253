"""Weather, clutter and noise time series by the spectral method of Zrnic (1975).

An independent reference for the Doppler tests: it shares no code with the simulator's
weather channel (which colours white sequences in the time domain, paper eq. 13-18) nor with
the processors. Zrnic, D. S. (1975), *Simulation of weatherlike Doppler spectra and
signals*, J. Appl. Meteor. 14, 619-620: the power spectrum is sampled on N frequency bins,
each bin gets an exponentially distributed power (mean = the spectral density there) and a
uniform random phase, and the inverse DFT is the series. Taking the first M of N >> M samples
removes the circular correlation of an N-point series (Zrnic's own recommendation).

Spectra are Gaussian in velocity, summed over the aliases of the Nyquist interval. The
velocity of bin k of an N-point DFT at sampling interval T is -lambda f_k / 2 (positive away
= negative Doppler frequency, the NEXRAD convention of the simulator).
"""

from __future__ import annotations

import numpy as np


def gaussian_density(
    velocity_ms: np.ndarray, mean_ms: float, width_ms: float, nyquist_ms: float
) -> np.ndarray:
    """Gaussian power density (per m/s, unit total power) aliased onto +-nyquist_ms."""
    width_ms = max(width_ms, 1e-6)
    out = np.zeros_like(velocity_ms, dtype=np.float64)
    for k in range(-3, 4):
        d = velocity_ms - mean_ms + 2 * k * nyquist_ms
        out += np.exp(-(d**2) / (2 * width_ms**2)) / (np.sqrt(2 * np.pi) * width_ms)
    return out


def spectral_series(
    rng: np.random.Generator,
    gates: int,
    pulses: int,
    prt_s: float,
    wavelength_m: float,
    components: list[tuple[float, float, float]],
    noise_w: float = 0.0,
    oversample: int = 16,
) -> np.ndarray:
    """Series (gate x pulse) of the sum of Gaussian components plus white noise.

    ``components``: (power W, mean velocity m/s, width m/s) per component, each an independent
    Gaussian process (weather, clutter). The noise is white with power ``noise_w``.
    """
    n = oversample * pulses
    nyquist = wavelength_m / (4 * prt_s)
    f = np.fft.fftfreq(n, prt_s)
    v = -wavelength_m * f / 2
    dv = 2 * nyquist / n
    density = np.zeros(n)
    for power, mean, width in components:
        d = gaussian_density(v, mean, width, nyquist)
        density += power * d / (d.sum() * dv) if d.sum() > 0 else 0.0
    bin_power = density * dv + noise_w / n  # mean power per bin; sums to the total
    p = -bin_power * np.log(rng.uniform(size=(gates, n)))
    phase = rng.uniform(0, 2 * np.pi, (gates, n))
    x = np.fft.ifft(np.sqrt(p) * np.exp(1j * phase), axis=-1) * n
    return x[:, :pulses]


def staggered_series(
    rng: np.random.Generator,
    gates: int,
    times_s: np.ndarray,
    wavelength_m: float,
    power_w: float,
    velocity_ms: float,
    width_ms: float,
    noise_w: float,
    step_s: float,
    oversample: int = 16,
) -> np.ndarray:
    """Series at pulse times ``times_s`` (multiples of ``step_s``): the spectral method on the
    uniform grid of ``step_s``, sampled at the staggered times."""
    idx = np.rint(np.asarray(times_s) / step_s).astype(int)
    full = spectral_series(
        rng,
        gates,
        int(idx[-1]) + 1,
        step_s,
        wavelength_m,
        [(power_w, velocity_ms, width_ms)],
        0.0,
        oversample,
    )
    noise = np.sqrt(noise_w / 2) * (
        rng.standard_normal((gates, idx.size)) + 1j * rng.standard_normal((gates, idx.size))
    )
    return full[:, idx] + noise
