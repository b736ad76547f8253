"""The weather channel's fidelity levels: expected, combined, covariance, monte_carlo.

The combined level draws each gate's series from the pattern- and range-weighted sum of its
cells' spectra. For a sum of independent Gaussian processes that is exact in distribution, so
its sample correlations must equal the weighted sum of the cells' autocorrelations (computed
here independently, from the Gaussian-spectrum formula, at lags the block never computes), and
its estimates must have the per-cell level's statistics.
"""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.processing.pulse_pair import pulse_pair
from pasim_blocks.signals import SPEED_OF_LIGHT
from pasim_blocks.weather.beams import azimuth_profile, cell_solid_angles
from pasim_blocks.weather.channel import WeatherChannel

from pasim_graph import Chunk

from .test_block_weather import chain_inputs, uniform_truth

PRT = 1 / 300
LAM = SPEED_OF_LIGHT / 2.8e9


def sheared_truth(n_gates=60, width=1.0, **fields):
    """A field uniform in range whose velocity changes across radials (azimuthal shear)."""
    truth = uniform_truth(n_gates=n_gates, WRADH=width, **fields)
    az = truth["azimuth"].values
    v = 6.0 * np.sin(np.deg2rad(az - 105.0) * 12)  # +-6 m/s over a few degrees
    truth["VRADH"] = (("radial", "gate"), np.repeat(v[:, None], n_gates, 1).astype(np.float32))
    return truth


def weather(inputs, beams, method, seed=3, fields=None, **params):
    block = WeatherChannel(name="weather", method=method, **params)
    chunk = Chunk(beams=beams, seed=seed, block_name="weather", options={"fields": fields})
    return block.process(inputs, chunk)


def theory_lags(inputs, lags, beam=0):
    """sum_j omega_j s_j r_j(l) for H, V and E[h* v] at each lag, from first principles.

    Uniform range, so the range weighting only scales: normalised by lag 0 it cancels.
    """
    truth, pattern = inputs["truth"], inputs["pattern"]
    beams = inputs["beams"]
    az = truth["azimuth"].values
    delta = (az - beams["azimuth"].values[beam] + 180) % 360 - 180
    d_az = pattern["azimuth_offset_deg"].values
    near = np.flatnonzero(np.abs(delta) <= np.abs(d_az).max() + 0.25)
    prof = azimuth_profile(
        pattern["power"].values[beam],
        pattern["elevation_offset_deg"].values,
        float(beams["elevation"].values[beam]),
    )
    omega = cell_solid_angles(prof, d_az, delta[near], 0.5)
    g = truth.sizes["gate"] // 2
    v = truth["VRADH"].values[near, g]
    w = truth["WRADH"].values[near, g]
    zdr = 10 ** (truth["ZDR"].values[near, g] / 10)
    rho = truth["RHOHV"].values[near, g]
    phi = np.deg2rad(truth["PHIDP"].values[near, g])
    a = np.pi * PRT / LAM
    r = np.exp(-8 * (a * w[:, None] * lags) ** 2) * np.exp(-4j * a * v[:, None] * lags)
    h = omega[0] @ r
    vv = omega[1] @ (r / zdr[:, None])
    x = np.sqrt(omega[0] * omega[1]) @ (r * (rho * np.exp(1j * phi) / np.sqrt(zdr))[:, None])
    return h, vv, x


def sample_lags(iq, lags):
    """Sample correlations averaged over beams and gates: E[x_{m+l} x_m^*] and E[h* v]."""
    h, v = iq[..., 0], iq[..., 1]
    n = h.shape[-1]
    out_h = np.array([np.mean(h[..., k:] * np.conj(h[..., : n - k])) for k in lags])
    out_v = np.array([np.mean(v[..., k:] * np.conj(v[..., : n - k])) for k in lags])
    x = np.mean(np.conj(h) * v)
    return out_h, out_v, x


@pytest.mark.parametrize("width", [1.0, 0.0])
def test_combined_draw_has_the_summed_covariance(width):
    """Sample lags 0-12 of the combined level against the weighted sum of cell ACFs.

    1,900 series of 64 pulses. Width 0 runs through the tone path (zero-width cells are
    random-amplitude tones, so a series never decorrelates and each counts once): the
    normalised sample correlation has a standard error of about 0.02 (measured over 8 seeds,
    mean difference within 1.5 standard errors); tolerance 0.06. Width 1 m/s runs through the
    spectral draw and is several times tighter.
    """
    beams = np.arange(10)
    inputs = chain_inputs(sheared_truth(n_gates=200, width=width), beams)
    out = weather(inputs, beams, "combined")
    lags = np.arange(13)
    iq = out["iq"][:, 5:-5].astype(np.complex128)
    s_h, s_v, s_x = sample_lags(iq, lags)
    th = [theory_lags(inputs, lags, beam=b) for b in beams]
    t_h = np.mean([t[0] for t in th], axis=0)
    t_v = np.mean([t[1] for t in th], axis=0)
    t_x = np.mean([t[2] for t in th], axis=0)
    np.testing.assert_allclose(s_h / s_h[0], t_h / t_h[0], atol=0.06)
    np.testing.assert_allclose(s_v / s_v[0], t_v / t_v[0], atol=0.06)
    assert abs(s_x / np.sqrt(s_h[0] * s_v[0]) - t_x[0] / np.sqrt(t_h[0] * t_v[0])) < 0.02
    # Absolute power against the block's own expected power (radar equation, tested apart).
    power = out["signal_power"][:, 5:-5].astype(np.float64).mean(axis=(0, 1))
    np.testing.assert_allclose([s_h[0].real, s_v[0].real], power, rtol=0.05)


def test_expected_level_recovers_a_uniform_truth_exactly():
    """With no gradient, smoothing changes nothing: the expected level returns the truth.

    The width is the truth's widened by the dish's scan modulation, sigma_scan = alpha lambda
    sqrt(ln 2) / (2 pi theta_1) (Doviak and Zrnic 1993, eq. 5.38; the pencil's 1-deg beam at
    the scan's rate), added in quadrature; ``width_model: truth`` gives the truth's width.
    """
    beams = np.arange(3)
    inputs = chain_inputs(uniform_truth(n_gates=20), beams)
    out = weather(inputs, beams, "expected")
    assert out["iq"].shape[2] == 0
    c = out["echo_correlations"][:, 3:-3]
    est = pulse_pair_from(c)
    assert np.allclose(est["VRADH"], 5.0, atol=1e-6)
    rate = np.deg2rad(float(inputs["beams"]["scan_rate"].values[0]))
    lam = SPEED_OF_LIGHT / 2.8e9
    sigma_scan = rate * lam * np.sqrt(np.log(2)) / (2 * np.pi * np.deg2rad(1.0))
    assert np.allclose(est["WRADH"], np.hypot(2.0, sigma_scan), atol=1e-4)
    as_given = weather(inputs, beams, "expected", width_model="truth")
    assert np.allclose(pulse_pair_from(as_given["echo_correlations"][:, 3:-3])["WRADH"], 2.0)
    assert np.allclose(est["ZDR"], 1.0, atol=1e-6)
    assert np.allclose(est["RHOHV"], 0.98, atol=1e-6)
    assert np.allclose(est["PHIDP"], 30.0, atol=1e-6)


def pulse_pair_from(c):
    from pasim_blocks.processing.pulse_pair import moments_from_correlations
    from pasim_blocks.signals import CORRELATION_PRODUCTS

    corr = {k: c[..., i] for i, k in enumerate(CORRELATION_PRODUCTS)}
    return moments_from_correlations(corr, 0.0, 0.0, PRT, LAM)


@pytest.mark.parametrize("method", ["combined", "covariance", "monte_carlo"])
def test_expected_correlations_are_the_mean_of_every_level(method):
    """The expected output is the ensemble mean of what each random level draws (lags 0, 1)."""
    beams = np.arange(6)
    inputs = chain_inputs(sheared_truth(n_gates=40), beams, pulses=32)
    out = weather(inputs, beams, method, drops_per_cell=64)
    iq = out["iq"][:, 4:-4].astype(np.complex128)
    c = out["echo_correlations"][:, 4:-4]
    r0 = np.mean(np.abs(iq[..., 0]) ** 2, axis=-1)
    r1 = np.mean(np.conj(iq[..., :-1, 0]) * iq[..., 1:, 0], axis=-1)
    assert np.mean(r0) / np.mean(c[..., 0].real) == pytest.approx(1.0, abs=0.06)
    assert abs(np.mean(r1) / np.mean(c[..., 2]) - 1) < 0.1


@pytest.mark.parametrize("method", ["expected", "combined", "covariance", "monte_carlo"])
def test_every_level_draws_each_beam_the_same_whatever_the_chunk(method):
    beams = np.arange(4)
    inputs = chain_inputs(sheared_truth(n_gates=20), beams, pulses=16)
    whole = weather(inputs, beams, method, drops_per_cell=16)
    for b in (0, 3):
        one_inputs = chain_inputs(inputs["truth"], np.array([b]), pulses=16)
        one = weather(one_inputs, np.array([b]), method, drops_per_cell=16)
        np.testing.assert_array_equal(one["iq"][0], whole["iq"][b])
        np.testing.assert_array_equal(one["echo_correlations"][0], whole["echo_correlations"][b])


@pytest.mark.parametrize("method", ["combined", "covariance", "monte_carlo"])
def test_asking_for_h_only_skips_v_and_keeps_h(method):
    """--outputs DBZH: the V channel is not drawn, and H is the very same numbers."""
    beams = np.arange(2)
    inputs = chain_inputs(sheared_truth(n_gates=20, width=0.5), beams, pulses=16)
    both = weather(inputs, beams, method, drops_per_cell=16)
    h_only = weather(inputs, beams, method, drops_per_cell=16, fields=("DBZH",))
    np.testing.assert_array_equal(both["iq"][..., 0], h_only["iq"][..., 0])
    assert both["iq"][..., 1].any() and not h_only["iq"][..., 1].any()


def test_single_polarisation_truth_draws_h_only():
    beams = np.arange(2)
    truth = uniform_truth(n_gates=20).drop_vars(["ZDR", "RHOHV", "PHIDP"])
    out = weather(chain_inputs(truth, beams, pulses=16), beams, "combined")
    assert out["iq"][..., 0].any() and not out["iq"][..., 1].any()
    assert out["calibration"].attrs["dual_polarization"] == 0


def test_float64_and_float32_agree_on_a_100_db_scene():
    """A 80 dBZ core beside -20 dBZ: the weak gates' power survives float32 sums.

    The weak gates out of the core's range weighting (over 6 gates away) must come back with
    their expected power at both precisions: sample power averaged over 10 beams x 30 gates
    (relative standard error ~ 0.02); tolerance 0.1.
    """
    beams = np.arange(10)
    truth = uniform_truth(n_gates=60, DBZH=-20.0)
    dbz = truth["DBZH"].values
    dbz[:, 10:14] = 80.0
    inputs = chain_inputs(truth, beams, pulses=32)
    p = {}
    for precision in ("float32", "float64"):
        out = weather(inputs, beams, "combined", precision=precision)
        weak = np.abs(out["iq"][:, 20:50, :, 0].astype(np.complex128)) ** 2
        p[precision] = weak.mean() / out["signal_power"][:, 20:50, 0].astype(np.float64).mean()
        assert np.isfinite(out["iq"]).all()
    assert p["float32"] == pytest.approx(1.0, abs=0.1)
    assert p["float64"] == pytest.approx(1.0, abs=0.1)


def test_combined_and_covariance_estimates_have_the_same_spread():
    """Per-gate std of the six estimates from both levels on the same sheared field.

    400 gates each: the std of a std estimate is ~ 1/sqrt(2 x 400) = 3.5 %; tolerance 12 %.
    """
    beams = np.arange(10)
    inputs = chain_inputs(sheared_truth(n_gates=50, width=1.5), beams)
    stds = {}
    for method in ("combined", "covariance"):
        iq = weather(inputs, beams, method)["iq"][:, 5:-5].astype(np.complex128)
        est = pulse_pair(iq[..., 0], iq[..., 1], 0.0, 0.0, PRT, LAM)
        stds[method] = {
            "DBZH": np.nanstd(10 * np.log10(est["S_H"]), axis=1).mean(),
            "ZDR": np.nanstd(est["ZDR"], axis=1).mean(),
            "RHOHV": np.nanstd(est["RHOHV"], axis=1).mean(),
            "PHIDP": np.nanstd(est["PHIDP"], axis=1).mean(),
        }
    for k in stds["combined"]:
        assert stds["combined"][k] / stds["covariance"][k] == pytest.approx(1.0, abs=0.12), k


def test_truth_read_for_a_narrower_sector_than_the_pattern_needs_is_refused():
    """A truth read for a sector must cover every beam's pattern grid, or the run stops."""
    beams = np.arange(2)
    inputs = chain_inputs(uniform_truth(n_gates=10), beams, pulses=8)  # beams at 100.5, 101.5
    inside = inputs | {"truth": inputs["truth"].isel(radial=slice(180, 230))}  # 90-115 deg
    weather(inside, beams, "combined")  # +-4 deg of pattern fits
    narrow = inputs | {"truth": inputs["truth"].isel(radial=slice(196, 230))}  # 98-115 deg
    with pytest.raises(ValueError, match="margin_deg"):
        weather(narrow, beams, "combined")
