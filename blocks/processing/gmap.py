"""GMAP, the Gaussian Model Adaptive Processing clutter filter (Siggia and Passarelli 2004).

Siggia, A. D. and R. E. Passarelli (2004), *Gaussian model adaptive processing (GMAP) for
improved ground clutter cancellation and moment calculation*, Proc. ERAD 2004, 67-73. On the
windowed periodogram of a dwell (:mod:`pasim_blocks.processing.spectral`) with a known noise
power N (N / M per bin), per gate:

1. Window. :func:`select_windows` picks it by the clutter-to-noise ratio (CNR): the clutter
   power is measured on a Hamming-windowed first look (below); a gate without clutter gets
   the rectangular window, the others the least aggressive of rectangular, Hamming, Blackman
   and Blackman-Harris whose clutter model reaches no more than one bin further from zero
   velocity than the narrowest of the four (the least variance that still contains the
   clutter's leakage: rectangular at low CNR, then Hamming, Blackman, Blackman-Harris).
2. Clutter model. The expected periodogram of a unit-power Gaussian clutter spectrum of the
   given width (the antenna's scan modulation and the clutter's own motion) centred on zero
   velocity, seen through the window, leakage included (:func:`clutter_shape`, exact). Its
   power is fitted on the three central bins (zero velocity and its two neighbours): their
   power above noise over the model's share in them. Where those three bins hold no more
   than their noise (3 N / M), the gate has no clutter and is left alone.
3. Removal. Every bin out to the outermost one where the fitted model stands above the noise
   level is removed (at least the three central bins, never more than all but the three
   bins at the Nyquist velocity).
4. Weather fit. From the bins that remain, noise subtracted bin by bin (N / M each, no
   clipping, so the noise cancels on average): lag 0, R0 = sum p_k, and lag 1, R1 = sum p_k
   exp(j pi v_k / v_a), of the spectrum's autocorrelation. The weather's Gaussian has power
   R0, mean velocity v_a / pi arg R1 and width v_a / pi sqrt(2 ln(R0 / |R1|)) (the
   Gaussian relation between lags 0 and 1 on the bins).
5. Refill. The removed bins get that Gaussian (aliased onto the Nyquist interval, summed
   over the bins to R0) plus the noise level. R0 and R1 are taken again over the whole
   refilled spectrum and 4-5 repeat until the power changes by less than 0.01 dB and the
   velocity by less than 0.05 % of the Nyquist interval (Siggia and Passarelli stop at
   0.2 dB and 0.5 %; the tighter stop lands on the iteration's fixed point, so the result
   does not depend on the path), at most ``max_iterations`` times.

6. Clutter check. Where the three central bins hold no more than 3 times what the refill
   (weather model plus noise) puts there, the "clutter" was the weather's own spectrum near
   zero velocity (Siggia and Passarelli's test compares those bins with the noise alone,
   which weather near zero velocity passes): the gate is left unfiltered. On weather alone
   the three bins' power is a gamma(3) variable, above 3 times its mean 0.6 % of the time.

The moments are then taken from the refilled spectrum by the spectral estimator. Weather
near zero velocity is partly removed with the clutter and rebuilt from its own Gaussian
tails: the filter's known bias where the weather's spectrum overlaps the removed bins. The
removed power over the filtered power is the clutter correction (dB), reported per gate.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.signal

#: Convergence: power change (dB) and velocity change (fraction of 2 v_a); tighter than
#: Siggia and Passarelli's 0.2 dB and 0.5 % (see the module's documentation).
POWER_TOLERANCE_DB = 0.01
VELOCITY_TOLERANCE = 0.0005

#: A gate has clutter only where its three central bins hold more than this times what the
#: weather's Gaussian and the noise put there (on weather alone the three bins' power is a
#: gamma(3) variable: it exceeds 3 times its mean with probability 0.6 %).
CLUTTER_FACTOR = 3.0

#: The windows GMAP chooses from, least aggressive first (scipy.signal.windows names).
GMAP_WINDOWS = ("boxcar", "hamming", "blackman", "blackmanharris")

#: The window of the first look that measures the clutter power (Siggia and Passarelli).
FIRST_LOOK_WINDOW = "hamming"


class GmapResult(NamedTuple):
    spectrum: np.ndarray  #: filtered spectrum (gate x bin, natural order)
    removed: np.ndarray  #: bool, bins replaced by the weather model
    correction_db: np.ndarray  #: 10 log10(power before / power after), noise excluded


def clutter_shape(w: np.ndarray, width_ms: float, prt_s: float, wavelength_m: float) -> np.ndarray:
    """Expected windowed periodogram (natural order) of a unit-power Gaussian clutter echo at
    zero velocity with spectrum width ``width_ms``: sum over lags of its autocorrelation
    exp(-8 (pi w l T / lambda)^2) times the window's overlap at that lag."""
    m = w.size
    lags = np.arange(-(m - 1), m)
    rho = np.exp(-8 * (np.pi * width_ms * lags * prt_s / wavelength_m) ** 2)
    overlap = np.array([np.sum(w[: m - abs(k)] * w[abs(k) :]) for k in lags])
    k = np.arange(m)
    phase = np.exp(-2j * np.pi * np.outer(k, lags) / m)
    shape = (phase @ (rho * overlap)).real / (m * np.sum(w**2))
    return np.maximum(shape, 0.0)


def gmap_window(name: str, pulses: int) -> np.ndarray:
    """One of :data:`GMAP_WINDOWS` (symmetric, peak 1), from scipy.signal.windows."""
    return np.asarray(scipy.signal.get_window(name, pulses, fftbins=False), np.float64)


def _central(m: int) -> np.ndarray:
    return np.array([0, 1, m - 1])


def clutter_amplitude(s: np.ndarray, noise_bin: np.ndarray, shape: np.ndarray) -> np.ndarray:
    """Clutter power fitted on the three central bins (0 where they hold no more than noise)."""
    c = _central(s.shape[-1])
    excess = s[:, c].sum(axis=-1) - 3 * noise_bin
    return np.maximum(excess, 0.0) / shape[c].sum()


def clutter_extent(amplitude: np.ndarray, noise_bin: np.ndarray, shape: np.ndarray) -> np.ndarray:
    """Half-width (bins from zero velocity) of the removal: the outermost bin where the
    clutter model stands above the noise, at least 1 where there is clutter, 0 where none,
    at most M / 2 - 2."""
    m = shape.size
    dist = np.minimum(np.arange(m), m - np.arange(m))
    above = amplitude[:, None] * shape[None, :] > noise_bin[:, None]
    reach = np.max(np.where(above, dist[None, :], 0), axis=-1)
    reach = np.where(amplitude > 0, np.maximum(reach, 1), 0)
    return np.minimum(reach, m // 2 - 2)


def select_windows(
    first_look: np.ndarray, noise_w: np.ndarray, width_ms: float, prt_s: float, wavelength_m: float
) -> np.ndarray:
    """Index into :data:`GMAP_WINDOWS` per gate, from the Hamming periodogram ``first_look``
    (gate x bin) and the noise power per gate (step 1 of the module's documentation)."""
    n_g, m = first_look.shape
    noise_bin = np.broadcast_to(np.asarray(noise_w, np.float64), (n_g,)) / m
    hamming = clutter_shape(gmap_window(FIRST_LOOK_WINDOW, m), width_ms, prt_s, wavelength_m)
    power = clutter_amplitude(first_look, noise_bin, hamming)
    reach = np.stack(
        [
            clutter_extent(
                power, noise_bin, clutter_shape(gmap_window(n, m), width_ms, prt_s, wavelength_m)
            )
            for n in GMAP_WINDOWS
        ]
    )
    fits = reach <= reach.min(axis=0) + 1
    choice = np.argmax(fits, axis=0)
    return np.where(power > 0, choice, 0)


def _lags(
    p: np.ndarray, v_bins: np.ndarray, nyquist: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Power, mean velocity and Gaussian width from lags 0 and 1 of noise-free bins ``p``."""
    r0 = p.sum(axis=-1)
    r1 = p @ np.exp(1j * np.pi * v_bins / nyquist)
    mean = nyquist / np.pi * np.angle(r1)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.log(r0 / np.abs(r1))
    width = nyquist / np.pi * np.sqrt(2 * np.maximum(np.nan_to_num(ratio, nan=0.0), 0.0))
    return r0, mean, width


def _gaussian_bins(
    power: np.ndarray, mean: np.ndarray, width: np.ndarray, v_bins: np.ndarray, nyquist: float
) -> np.ndarray:
    """Power per bin of Gaussians (gate) aliased onto the Nyquist interval, sums to power."""
    wd = np.maximum(width, 1e-3)[:, None]
    g = np.zeros((power.size, v_bins.size))
    for k in (-2, -1, 0, 1, 2):
        d = v_bins[None, :] - mean[:, None] + 2 * k * nyquist
        g += np.exp(-(d**2) / (2 * wd**2))
    total = g.sum(axis=-1, keepdims=True)
    return power[:, None] * np.divide(g, total, out=np.zeros_like(g), where=total > 0)


def gmap(
    spectrum: np.ndarray,
    noise_w: np.ndarray,
    shape: np.ndarray,
    v_bins: np.ndarray,
    nyquist: float,
    apply: np.ndarray | None = None,
    max_iterations: int = 200,
) -> GmapResult:
    """Filter spectra (gate x bin, natural order) with GMAP; ``noise_w`` per gate (W).

    ``shape``: the clutter model of :func:`clutter_shape` for the spectra's window;
    ``apply``: the gates to filter (all when None); others pass unchanged, as do gates whose
    three central bins hold no more than noise.
    """
    s = np.array(spectrum, dtype=np.float64, copy=True)
    n_g, m = s.shape
    noise_bin = np.broadcast_to(np.asarray(noise_w, np.float64), (n_g,)) / m
    apply = np.ones(n_g, bool) if apply is None else np.asarray(apply, bool)
    # 2-3. Clutter power from the three central bins; removal out to where it meets noise.
    reach = np.where(
        apply, clutter_extent(clutter_amplitude(s, noise_bin, shape), noise_bin, shape), 0
    )
    dist = np.minimum(np.arange(m), m - np.arange(m))
    removed = (dist[None, :] <= reach[:, None]) & (reach[:, None] > 0)
    before = s.sum(axis=-1)
    active = np.flatnonzero(reach > 0)
    # 4. The weather's Gaussian from the bins that remain (noise subtracted, not clipped).
    p = np.where(removed[active], 0.0, s[active] - noise_bin[active, None])
    power, mean, width = _lags(p, v_bins, nyquist)
    for _ in range(max_iterations):
        if active.size == 0:
            break
        # 5. Refill the removed bins; the moments again from the whole spectrum.
        model = _gaussian_bins(np.maximum(power, 0.0), mean, width, v_bins, nyquist)
        s[active] = np.where(removed[active], model + noise_bin[active, None], s[active])
        p_new, m_new, w_new = _lags(s[active] - noise_bin[active, None], v_bins, nyquist)
        with np.errstate(divide="ignore", invalid="ignore"):
            dp = np.abs(10 * np.log10(p_new / power))
        dv = np.abs(np.mod(m_new - mean + nyquist, 2 * nyquist) - nyquist)
        done = (
            (np.nan_to_num(dp, nan=np.inf) < POWER_TOLERANCE_DB)
            & (dv < VELOCITY_TOLERANCE * 2 * nyquist)
        ) | (p_new <= 0) & (power <= 0)
        keep = ~done
        active, power, mean, width = active[keep], p_new[keep], m_new[keep], w_new[keep]
    # 6. No clutter after all where the three central bins hold no more than CLUTTER_FACTOR
    # times what the refill (weather model plus noise) puts there: the filter is undone.
    c = _central(m)
    fitted = removed.any(axis=-1) & (
        spectrum[:, c].sum(axis=-1) <= CLUTTER_FACTOR * s[:, c].sum(axis=-1)
    )
    s[fitted] = spectrum[fitted]
    removed[fitted] = False
    after = s.sum(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        noise = noise_bin * m
        corr = 10 * np.log10(np.maximum(before - noise, 0) / np.maximum(after - noise, 0))
    return GmapResult(s, removed, np.where(removed.any(axis=-1), corr, 0.0))


def clutter_phase_alignment(iq: np.ndarray) -> np.ndarray:
    """CPA = |sum_m x_m| / sum_m |x_m| along the pulse axis (Hubbert et al. 2009): near 1 for
    a stationary (clutter) echo, near 1 / sqrt(M) for weather away from zero velocity."""
    num = np.abs(iq.sum(axis=-1))
    den = np.abs(iq).sum(axis=-1)
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)
