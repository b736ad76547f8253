"""The spectral moment estimator and the GMAP clutter filter on independent time series.

The series come from ``tests.reference.spectral_series``: the spectral method of Zrnic
(1975), which shares no code with the simulator's weather channel or clutter block. The
truth is what went into the series. Scenario of issue #24: 64 pulses, PRT 1 ms, S band,
weather at SNR 30 dB with velocity 5 m/s and width 2 m/s, clutter 40 dB above the weather
(clutter-to-signal ratio, CSR) with a 0.25 m/s wide spectrum at zero velocity.

What each test compares against:

* the spectral estimator without clutter: the truth, within 5 standard errors of the mean
  (the standard error from the gates' own spread); it must agree with pulse-pair's theory
  level of noise within a factor that the window's loss of independent samples explains
  (not tested here: the window's variance is a design figure, reported in docs/doppler.md);
* GMAP (Siggia and Passarelli 2004): reflectivity bias under 1 dB and velocity bias under
  1 m/s after filtering, against several dB (the clutter's own power) and near-zero velocity
  before, as the issue asks; the reflectivity bias is the mean over gates of the dB error, as
  the scorer takes it;
* weather at zero velocity: the filter's known bias (it removes weather with the clutter and
  rebuilds it from its Gaussian tails) is measured and must be a loss (negative), under the
  clutter's several dB; its value is the table in docs/doppler.md.
"""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.processing.gmap import clutter_phase_alignment, clutter_shape, gmap
from pasim_blocks.processing.spectral import (
    bin_velocities,
    moments_from_spectrum,
    periodogram,
    window,
)

from tests.reference.spectral_series import spectral_series

WAVELENGTH_M = 299_792_458.0 / 2.8e9
PRT_S = 1e-3
M = 64
GATES = 2000
NOISE_W = 1.0
SIGNAL_W = 1000.0  # SNR 30 dB
CLUTTER_WIDTH_MS = 0.25
NYQUIST = WAVELENGTH_M / (4 * PRT_S)


def series(velocity_ms: float, csr_db: float | None, seed: int) -> np.ndarray:
    comps = [(SIGNAL_W, velocity_ms, 2.0)]
    if csr_db is not None:
        comps.append((SIGNAL_W * 10 ** (csr_db / 10), 0.0, CLUTTER_WIDTH_MS))
    gen = np.random.default_rng(seed)
    return spectral_series(gen, GATES, M, PRT_S, WAVELENGTH_M, comps, NOISE_W)


def estimate(x: np.ndarray, name: str, filtered: bool) -> dict[str, np.ndarray]:
    w = window(name, M)
    s = periodogram(x, w)
    out: dict[str, np.ndarray] = {}
    if filtered:
        shape = clutter_shape(w, CLUTTER_WIDTH_MS, PRT_S, WAVELENGTH_M)
        res = gmap(
            s, np.full(GATES, NOISE_W), shape, bin_velocities(M, PRT_S, WAVELENGTH_M), NYQUIST
        )
        s = res.spectrum
        out["correction_db"] = res.correction_db
    out |= moments_from_spectrum(s, w, NOISE_W, PRT_S, WAVELENGTH_M)
    return out


def dbz_bias(est: dict[str, np.ndarray]) -> float:
    with np.errstate(invalid="ignore", divide="ignore"):
        err = 10 * np.log10(est["S_H"] / SIGNAL_W)
    return float(np.nanmean(err))


def velocity_bias(est: dict[str, np.ndarray], truth: float) -> float:
    d = np.mod(est["VRADH"] - truth + NYQUIST, 2 * NYQUIST) - NYQUIST
    return float(np.nanmean(d))


@pytest.mark.parametrize("name", ["rectangular", "hann", "blackman"])
def test_spectral_moments_unbiased_without_clutter(name):
    """Velocity and width from the windowed periodogram match the truth (5 standard errors
    plus the width's finite-dwell bias of a few hundredths of a m/s)."""
    est = estimate(series(5.0, None, 1), name, filtered=False)
    v, w = est["VRADH"], est["WRADH"]
    se_v = np.nanstd(v) / np.sqrt(v.size)
    se_w = np.nanstd(w) / np.sqrt(w.size)
    assert abs(np.nanmean(v) - 5.0) < 5 * se_v
    assert abs(np.nanmean(w) - 2.0) < 5 * se_w + 0.1
    assert np.isfinite(v).mean() > 0.99


def test_gmap_removes_clutter_40db():
    """Issue #24: CSR 40 dB, SNR 30 dB, v 5 m/s, w 2 m/s, 64 pulses, PRT 1 ms.

    Before the filter the clutter dominates (tens of dB of reflectivity bias, velocity near
    zero); after GMAP with the Blackman-Harris window the reflectivity bias is under 1 dB
    and the velocity bias under 1 m/s, and the removed power is about the 40 dB put in."""
    x = series(5.0, 40.0, 2)
    before = estimate(x, "blackman_harris", filtered=False)
    after = estimate(x, "blackman_harris", filtered=True)
    assert dbz_bias(before) > 30.0
    assert abs(np.nanmean(before["VRADH"])) < 0.5
    assert abs(dbz_bias(after)) < 1.0
    assert abs(velocity_bias(after, 5.0)) < 1.0
    assert 37.0 < np.median(after["correction_db"]) < 43.0


def test_gmap_window_leakage_limits_suppression():
    """With the Blackman window (-58 dB sidelobes) the clutter leaks above the noise over
    most of the spectrum at a clutter-to-noise ratio of 70 dB, and GMAP cannot recover the
    weather: the window sets the achievable suppression (Siggia and Passarelli 2004)."""
    after = estimate(series(5.0, 40.0, 3), "blackman", filtered=True)
    assert abs(dbz_bias(after)) > 3.0 or abs(velocity_bias(after, 5.0)) > 1.0


def test_gmap_bias_at_zero_velocity_is_reported():
    """Weather at zero velocity under the same clutter: GMAP removes some weather with the
    clutter. The measured bias (docs/doppler.md) is a loss of reflectivity, smaller than
    the clutter's own 40 dB, and the velocity stays unbiased (a symmetric loss)."""
    x = series(0.0, 40.0, 4)
    after = estimate(x, "blackman_harris", filtered=True)
    clean = estimate(series(0.0, None, 4), "blackman_harris", filtered=False)
    bias = dbz_bias(after) - dbz_bias(clean)
    assert -10.0 < bias < -0.5
    assert abs(velocity_bias(after, 0.0)) < 0.5


def test_clutter_phase_alignment_separates_clutter():
    """CPA is near 1 for clutter-dominated gates and small for weather away from zero."""
    assert np.median(clutter_phase_alignment(series(5.0, 40.0, 5))) > 0.8
    assert np.median(clutter_phase_alignment(series(5.0, None, 5))) < 0.3
