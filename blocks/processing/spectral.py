"""Spectral (periodogram) moment estimation: windowed power spectra and the moments from them.

A dwell's M samples x_m are windowed (w_m, a scipy.signal window) and transformed; the
periodogram S_k = |sum_m w_m x_m e^(-j 2 pi k m / M)|^2 / (M sum_m w_m^2) is power per bin
(sum_k S_k = the windowed mean power; white noise of power N gives N / M per bin, whatever the
window). The moments come from the spectrum's own autocorrelation, its inverse DFT:

- power: sum_k S_k - N;
- velocity: -lambda / (4 pi T) arg R(1), R(1) = sum_k S_k e^(j 2 pi k / M), which is the
  circular mean of the spectrum (the spectral first moment on the Nyquist circle);
- width: the Gaussian-spectrum relation lambda / (2 sqrt(2) pi T) sqrt(ln(S / |R(1)|)) on
  R(1) divided by the window's lag-1 overlap sum_m w_m w_(m+1) / sum_m w_m^2 (the taper
  lowers the lag-1 correlation of the windowed series by that much; the circular wrap term
  w_(M-1) w_0 is zero for the tapered windows and 1 / M of a long-decorrelated lag for the
  rectangular one).

So a filter that edits the spectrum (:mod:`pasim_blocks.processing.gmap`) hands its result
to the same estimator. With the rectangular window and no filter the estimate is the
pulse-pair one up to that wrap term.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.signal

from pasim_graph import Chunk, Output, Param
from pasim_graph.fm301 import MOMENT_FIELDS

from ..signals import MOMENTS
from ..timing import cohere_first_trip
from .gmap import (
    FIRST_LOOK_WINDOW,
    GMAP_WINDOWS,
    clutter_phase_alignment,
    clutter_shape,
    gmap,
    gmap_window,
    select_windows,
)
from .moment_processor import MomentProcessor

#: Windows offered, by their name in graph files -> scipy.signal.windows name.
WINDOWS = {
    "rectangular": "boxcar",
    "hann": "hann",
    "hamming": "hamming",
    "blackman": "blackman",
    "blackman_harris": "blackmanharris",
}


def window(name: str, pulses: int) -> np.ndarray:
    """The data window (symmetric, peak 1) of ``pulses`` samples."""
    if name not in WINDOWS:
        raise ValueError(f"unknown window {name!r}; known: {', '.join(WINDOWS)}")
    return np.asarray(scipy.signal.get_window(WINDOWS[name], pulses, fftbins=False), np.float64)


def periodogram(iq: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Power per Doppler bin (natural DFT order) along the last axis; sums to the mean power."""
    x = np.fft.fft(iq * w, axis=-1)
    return (x.real**2 + x.imag**2) / (w.size * np.sum(w**2))


def lag1_overlap(w: np.ndarray) -> float:
    """sum_m w_m w_(m+1) / sum_m w_m^2: the window's factor on the lag-1 correlation."""
    return float(np.sum(w[:-1] * w[1:]) / np.sum(w**2))


def bin_velocities(pulses: int, prt_s: float, wavelength_m: float) -> np.ndarray:
    """Velocity of each DFT bin (natural order), m/s, positive away."""
    return -wavelength_m * np.fft.fftfreq(pulses, prt_s) / 2


def spectral_correlations(spectrum: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lag-0 power and window-corrected lag-1 correlation of a periodogram (last axis)."""
    m = spectrum.shape[-1]
    r0 = spectrum.sum(axis=-1)
    r1 = spectrum @ np.exp(2j * np.pi * np.arange(m) / m)
    return r0, r1 / lag1_overlap(w)


def moments_from_spectrum(
    spectrum: np.ndarray,
    w: np.ndarray,
    noise_w: float | np.ndarray,
    prt_s: float,
    wavelength_m: float,
) -> dict[str, np.ndarray]:
    """Noise-corrected power ``S_H`` (W), velocity ``VRADH`` and width ``WRADH`` (m/s).

    NaN where the corrected power is not positive (as the pulse-pair estimator).
    """
    r0, r1 = spectral_correlations(spectrum, w)
    power = r0 - noise_w
    ok = (power > 0) & (np.abs(r1) > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        velocity = -wavelength_m / (4 * np.pi * prt_s) * np.angle(r1)
        ratio = np.log(np.where(ok, power, np.nan) / np.abs(r1))
        width = wavelength_m / (2 * np.sqrt(2) * np.pi * prt_s) * np.sqrt(np.maximum(ratio, 0))
    nan = np.float64(np.nan)
    return {
        "S_H": power,
        "VRADH": np.where(ok, velocity, nan),
        "WRADH": np.where(ok, width, nan),
    }


class SpectralProcessor(MomentProcessor):
    """Moments from the windowed periodogram, optionally after the GMAP clutter filter.

    Per gate and channel the dwell is windowed (``window``: rectangular, Hann, Hamming,
    Blackman or 4-term Blackman-Harris, from scipy.signal) and transformed; power, velocity
    and width come from the spectrum (:func:`moments_from_spectrum`). With ``clutter_filter``
    ``gmap`` each channel's spectrum is first filtered by GMAP (Siggia and Passarelli 2004,
    :mod:`pasim_blocks.processing.gmap`) on the gates ``clutter_detection`` selects: ``all``,
    or ``cpa`` (the gates whose H clutter phase alignment reaches ``cpa_threshold``, the
    stationarity test at the heart of NEXRAD's clutter mitigation decision, CMD). ZDR comes
    from the filtered powers; rho_hv and phi_DP from the H-V cross-spectrum on the bins GMAP
    kept in both channels. ``CCORH`` is the clutter power removed (dB; 0 where nothing was).
    The window's leakage sets how much clutter can be removed: a narrow clutter spectrum is
    spread by the window's sidelobes (-31 dB Hann, -58 dB Blackman, -92 dB Blackman-Harris)
    over the whole spectrum, so a clutter-to-noise ratio above the sidelobe level plus
    10 log10(M) needs a lower-sidelobe window. Simultaneous transmission (SHV) only. A
    phase-coded scan is cohered to the first trip before anything else (the clutter test,
    GMAP and the moments), as ``processor.pulse_pair`` does: first-trip weather and ground
    clutter are then the uncoded ones, clutter at zero velocity.
    """

    moments = Output(
        MOMENTS, store="moments", doc="estimated moments", fields=(*MOMENT_FIELDS, "CCORH")
    )

    window = Param(
        "hann",
        type="str",
        choices=(*WINDOWS, "auto"),
        doc="data window of the periodogram; auto: GMAP's choice per gate by clutter-to-noise "
        "ratio (rectangular where no clutter, then Hamming, Blackman, Blackman-Harris)",
    )
    clutter_filter = Param(
        "none", type="str", choices=("none", "gmap"), doc="clutter filter: none or gmap"
    )
    clutter_width_ms = Param(
        0.25,
        units="m/s",
        min=0.01,
        max=5.0,
        doc="spectrum width of the clutter model GMAP removes",
    )
    clutter_detection = Param(
        "all",
        type="str",
        choices=("all", "cpa"),
        doc="gates GMAP filters: all, or cpa (clutter phase alignment test)",
    )
    cpa_threshold = Param(
        0.5, min=0.0, max=1.0, doc="clutter phase alignment at or above which a gate is clutter"
    )

    def _estimate(
        self,
        x: np.ndarray,
        noise: np.ndarray,
        apply: np.ndarray,
        w: np.ndarray,
        prt: float,
        lam: float,
        dual: bool,
        gmap_on: bool,
    ) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """Moments (and the clutter correction) of gates x (gate x pulse x channel) seen
        through one window ``w``."""
        n, m = x.shape[:2]
        nyquist = lam / (4 * prt)
        v_bins = bin_velocities(m, prt, lam)
        shape = clutter_shape(w, self.p["clutter_width_ms"], prt, lam)
        spectra, kept = [], []
        correction = np.zeros(n)
        for k in range(2 if dual else 1):
            s = periodogram(x[..., k], w)
            if gmap_on:
                res = gmap(s, noise[:, k], shape, v_bins, nyquist, apply)
                s = res.spectrum
                kept.append(~res.removed)
                if k == 0:
                    correction = res.correction_db
            spectra.append(s)
        est = moments_from_spectrum(spectra[0], w, noise[:, 0], prt, lam)
        if dual:
            p_v = spectra[1].sum(axis=-1) - noise[:, 1]
            f = np.fft.fft(x * w[None, :, None], axis=1)
            cross = np.conj(f[..., 0]) * f[..., 1] / (m * np.sum(w**2))
            keep = kept[0] & kept[1] if kept else np.ones(cross.shape, bool)
            n_h = noise[:, :1] / m
            n_v = noise[:, 1:2] / m
            r_hv = np.where(keep, cross, 0).sum(axis=-1)
            s_h = np.where(keep, spectra[0] - n_h, 0).sum(axis=-1)
            s_v = np.where(keep, spectra[1] - n_v, 0).sum(axis=-1)
            ok = (est["S_H"] > 0) & (p_v > 0) & (s_h > 0) & (s_v > 0)
            with np.errstate(divide="ignore", invalid="ignore"):
                est["ZDR"] = 10 * np.log10(np.where(ok, est["S_H"] / p_v, np.nan))
                est["RHOHV"] = np.abs(r_hv) / np.sqrt(np.where(ok, s_h * s_v, np.nan))
                est["PHIDP"] = np.where(ok, np.mod(np.rad2deg(np.angle(r_hv)), 360.0), np.nan)
        return est, correction

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        d = self.dwell(inputs, chunk)
        iq, noise, prt, lam = d.iq, d.noise, d.prt_s, d.wavelength_m
        if chunk.expected:
            raise ValueError(
                f"block '{self.name}': the spectral processor needs pulses; the weather "
                "channel's method 'expected' draws none: use processor.pulse_pair, or a "
                "level that draws them (combined or slower)"
            )
        if iq.shape[2] < 4:
            raise ValueError(
                f"the spectral processor needs at least 4 pulses per dwell, got {iq.shape[2]}"
            )
        iq = cohere_first_trip(iq, d.beams)
        dual = d.dual
        m = iq.shape[2]
        nyquist = lam / (4 * prt)
        n_b, n_g = iq.shape[:2]
        x = iq.reshape(n_b * n_g, m, -1).astype(np.complex128)
        nz = noise.reshape(n_b * n_g, -1)
        apply = np.ones(n_b * n_g, bool)
        if self.p["clutter_detection"] == "cpa":
            apply = clutter_phase_alignment(x[..., 0]) >= self.p["cpa_threshold"]
        gmap_on = self.p["clutter_filter"] == "gmap"
        if self.p["window"] == "auto":
            # GMAP's own choice by clutter-to-noise ratio (Siggia and Passarelli 2004).
            first = periodogram(x[..., 0], gmap_window(FIRST_LOOK_WINDOW, m))
            choice = select_windows(first, nz[:, 0], self.p["clutter_width_ms"], prt, lam)
            choice = np.where(apply, choice, 0)
            groups = [(gmap_window(name, m), choice == i) for i, name in enumerate(GMAP_WINDOWS)]
        else:
            groups = [(window(self.p["window"], m), np.ones(n_b * n_g, bool))]
        est: dict[str, np.ndarray] = {}
        correction = np.zeros(n_b * n_g)
        for w, sel in groups:
            if not sel.any():
                continue
            part, corr = self._estimate(x[sel], nz[sel], apply[sel], w, prt, lam, dual, gmap_on)
            for k, v in part.items():
                est.setdefault(k, np.full(n_b * n_g, np.nan))[sel] = v
            correction[sel] = corr
        est = {k: v.reshape(n_b, n_g) for k, v in est.items()}
        out = self.moments_output(est, noise[..., 0], d, chunk, nyquist)
        ds = out["moments"]
        if chunk.wants("CCORH"):
            ds["CCORH"] = (
                ("beam", "range"),
                correction.reshape(n_b, n_g).astype(np.float32),
                {"units": "dB", "long_name": "clutter power removed by the clutter filter, H"},
            )
        return out
