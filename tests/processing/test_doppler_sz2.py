"""SZ-2 phase coding: two overlaid trips separated (processor.sz2, scan.ppi phase_code).

What each test compares against:

* the issue's case on series from the spectral method of Zrnic (1975)
  (``tests.reference.spectral_series``, no code shared with the weather channel), each trip
  multiplied by the transmit phase of the pulse that made it: 64 pulses, PRT 1 ms, widths
  2 m/s, the stronger trip at SNR 30 dB, the weaker 10 dB below and 10 m/s apart: both
  velocities recovered with std under 1.5 m/s (and unbiased within 0.3 m/s), powers within
  1 dB of what went in;
* beyond the recoverable region the weak trip is censored, not estimated: at 40 dB (the weak
  trip 10 dB below the noise) by its SNR, and at high SNR with a 4 m/s strong trip 60 dB
  above it by the strong trip's leakage through the notch (95 % of gates at least);
* random phase coding, the simpler alternative: the strong trip's velocity is recovered
  (std under 1.5 m/s), the weak trip acting as white noise;
* the whole chain (sz2_folding.yaml): a 20 dBZ field with a 40 dBZ storm at 190-210 km seen
  with PRT 1 ms and SZ(8/64): the storm recovered at its own range and the 20 dBZ trip-1
  echo under it at 40-60 km, each within 1 dB of the truth, velocities within 0.3 m/s.
"""

from __future__ import annotations

import numpy as np
from pasim_blocks.processing.sz2 import separate_trips, weak_censored
from pasim_blocks.timing import sz_code

from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graph import load
from tests.reference.spectral_series import spectral_series

from ..conftest import GRAPHS

WAVELENGTH_M = 299_792_458.0 / 2.8e9
PRT_S = 1e-3
M = 64
GATES = 2000
NYQUIST = WAVELENGTH_M / (4 * PRT_S)
DOPPLER_THRESHOLD_DB = 3.5  # the processor's default censoring of velocity


def overlaid(psi, strong_snr_db, ratio_db, strong_width=2.0, seed=0):
    gen = np.random.default_rng(seed)
    p_s = 10 ** (strong_snr_db / 10)
    p_w = p_s / 10 ** (ratio_db / 10)
    s1 = spectral_series(gen, GATES, M, PRT_S, WAVELENGTH_M, [(p_s, 5.0, strong_width)])
    s2 = spectral_series(gen, GATES, M, PRT_S, WAVELENGTH_M, [(p_w, 15.0, 2.0)])
    noise = np.sqrt(0.5) * (gen.standard_normal((GATES, M)) + 1j * gen.standard_normal((GATES, M)))
    x = s1 * np.exp(1j * psi) + s2 * np.exp(1j * np.roll(psi, 1)) + noise
    return separate_trips(x, psi, np.ones(GATES), PRT_S, WAVELENGTH_M), p_s, p_w


def err(v, truth):
    return np.mod(v - truth + NYQUIST, 2 * NYQUIST) - NYQUIST


def test_issue_case_both_trips_recovered():
    est, p_s, p_w = overlaid(sz_code(8, 64), 30.0, 10.0)
    assert (est["strong"] == 1).all()
    for v, truth in ((est["V1"], 5.0), (est["V2"], 15.0)):
        e = err(v, truth)
        assert e.std() < 1.5
        assert abs(e.mean()) < 0.3
    assert abs(10 * np.log10(np.mean(est["P1"]) / p_s)) < 1.0
    assert abs(10 * np.log10(np.mean(est["P2"]) / p_w)) < 1.0
    assert weak_censored(est, 60.0, 10.0).mean() < 0.05


def test_weak_trip_below_noise_is_censored():
    est, _, _ = overlaid(sz_code(8, 64), 30.0, 40.0, seed=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        snr_db = 10 * np.log10(est["P2"])
    censored = weak_censored(est, 60.0, 10.0) | ~(snr_db >= DOPPLER_THRESHOLD_DB)
    assert censored.mean() >= 0.95


def test_weak_trip_under_strong_leakage_is_censored():
    est, _, _ = overlaid(sz_code(8, 64), 80.0, 60.0, strong_width=4.0, seed=2)
    assert weak_censored(est, 60.0, 10.0).mean() >= 0.95


def test_random_phase_recovers_the_strong_trip():
    psi = np.random.default_rng(7).uniform(0, 2 * np.pi, M)
    est, _, _ = overlaid(psi, 30.0, 10.0, seed=3)
    e = err(est["V1"], 5.0)
    assert e.std() < 1.5
    assert abs(e.mean()) < 0.3


def test_chain_recovers_both_trips():
    sweep = LocalExecutor(load(GRAPHS / "sz2_folding.yaml"), RunOptions(seed=5)).run()
    r = sweep["range"].values
    z, v = sweep["DBZH"].values, sweep["VRADH"].values
    r_a = 299_792_458.0 * PRT_S / 2
    for lo, hi, truth in ((192e3, 208e3, 40.0), (192e3 - r_a, 208e3 - r_a, 20.0)):
        sel = (r > lo) & (r < hi)
        assert abs(np.nanmean(z[:, sel]) - truth) < 1.0
        assert abs(np.nanmean(v[:, sel]) - 5.0) < 0.3
        assert np.isfinite(z[:, sel]).mean() > 0.95
