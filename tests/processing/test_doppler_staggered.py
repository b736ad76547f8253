"""Staggered PRT (scan.ppi ``stagger``, processor.staggered): Torres, Dubel and Zrnic (2004).

What each test compares against:

* the dealiasing rule on exact (noise-free) correlations: the true velocity everywhere on the
  extended interval, for both ratios (an identity of the rule);
* the issue's case through the whole chain (uniform scene, weather channel drawing on the
  staggered pulse times, receiver noise): T1 = 1 ms, T2 = 1.5 ms at 2.8 GHz (Nyquist 26.8
  and 17.8 m/s, extended 53.5 m/s), v = 40 m/s, w = 2 m/s, SNR 20 dB, 64 pulses: bias under
  1 m/s, std within 15 % of the first-order theory of ``tests.reference.staggered`` (Isserlis
  on the exact staggered covariance), dealiasing errors (|error| above v_a1) on under 5 % of
  gates;
* the same statistics on series from the spectral method of Zrnic (1975)
  (``tests.reference.spectral_series``), which shares no code with the weather channel;
* the 3/4 ratio at -60 m/s (extended interval 80.3 m/s) through the chain;
* width: the two-lag ratio estimator's mean within 0.3 m/s of the truth (2 m/s);
* the uniform pulse-pair processor refuses a staggered scan.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from pasim_blocks.processing.staggered import staggered_correlations, staggered_velocity_width

from pasim_graph.executor import BlockError, LocalExecutor, RunOptions
from pasim_graph.graph import load
from tests.reference.spectral_series import staggered_series
from tests.reference.staggered import staggered_times, v1_std

from ..conftest import GRAPHS

WAVELENGTH_M = 299_792_458.0 / 2.8e9
T1 = 1e-3


def run(overrides: dict | None = None):
    graph = load(GRAPHS / "uniform_staggered.yaml", overrides or {})
    return LocalExecutor(graph, RunOptions(seed=2)).run()


def check(err: np.ndarray, theory: float) -> None:
    err = err[np.isfinite(err)]
    va1 = WAVELENGTH_M / (4 * T1)
    wrong = np.abs(err) > va1
    assert wrong.mean() < 0.05
    good = err[~wrong]
    assert abs(good.mean()) < 1.0
    assert abs(good.std() / theory - 1) < 0.15


@pytest.mark.parametrize("ratio", [Fraction(2, 3), Fraction(3, 4)])
def test_rule_is_exact_on_the_extended_interval(ratio):
    t2 = T1 / float(ratio)
    ve = WAVELENGTH_M / (4 * (t2 - T1))
    v = np.linspace(-ve, ve, 2001)[:-1]
    r1 = np.exp(-4j * np.pi * v * T1 / WAVELENGTH_M)
    r2 = 0.9 * np.exp(-4j * np.pi * v * t2 / WAVELENGTH_M)
    got, _ = staggered_velocity_width(r1, r2, T1, ratio, WAVELENGTH_M)
    np.testing.assert_allclose(got, v, atol=1e-9)


def test_issue_case_through_the_chain():
    sweep = run()
    assert float(sweep["nyquist_velocity"].values[0]) == pytest.approx(53.53, abs=0.01)
    theory = v1_std(T1, 2 / 3, 64, WAVELENGTH_M, 40.0, 2.0, 20.0)
    check(sweep["error_VRADH"].values.ravel(), theory)
    w = sweep["WRADH"].values
    assert abs(np.nanmean(w) - 2.0) < 0.3


def test_issue_case_on_independent_series():
    gen = np.random.default_rng(5)
    times = staggered_times(T1, 2 / 3, 64)
    x = staggered_series(gen, 4000, times, WAVELENGTH_M, 100.0, 40.0, 2.0, 1.0, T1 / 2)
    r1, r2 = staggered_correlations(x)
    v, w = staggered_velocity_width(r1, r2, T1, Fraction(2, 3), WAVELENGTH_M)
    ve = WAVELENGTH_M / (4 * 0.5e-3)
    err = np.mod(v - 40.0 + ve, 2 * ve) - ve
    check(err, v1_std(T1, 2 / 3, 64, WAVELENGTH_M, 40.0, 2.0, 20.0))
    assert abs(np.mean(w) - 2.0) < 0.3


def test_three_quarters_through_the_chain():
    sweep = run({"scan.stagger": "3/4", "scene.velocity_ms": -60.0})
    assert float(sweep["nyquist_velocity"].values[0]) == pytest.approx(80.30, abs=0.01)
    theory = v1_std(T1, 3 / 4, 64, WAVELENGTH_M, -60.0, 2.0, 20.0)
    check(sweep["error_VRADH"].values.ravel(), theory)


def test_pulse_pair_refuses_a_staggered_scan():
    overrides = {"scan.stagger": "2/3", "scan.azimuth_stop_deg": 2.0}
    graph = load(GRAPHS / "uniform_ideal.yaml", overrides)
    with pytest.raises(BlockError, match="staggered"):
        LocalExecutor(graph, RunOptions()).run()
