"""Tests of the theoretical statistics of the pulse-pair moments (``blocks/theory.py``).

What each test compares against:

* the lag sums: the Isserlis covariances written as traces of 2M x 2M matrices,
  ``Cov(z^H A z, z^H B z) = tr(A Sigma B Sigma)``, built here from the covariance of the I/Q;
* the derivatives: finite differences of the estimator functions themselves;
* (a) the delta method: a brute-force Monte Carlo of ``ppp.pulse_pair`` on dual-polarisation
  I/Q drawn here (Cholesky colouring, with numpy, of the joint H-V covariance of a Gaussian
  spectrum plus white noise), 20,000 dwells per parameter set. Tolerances: the MC's own
  sampling error (std of a std about 1/sqrt(2n) = 0.5 %, heavier tails for dB and rho) plus
  the delta method's neglected relative terms of order 1/M_I (M_I independent samples), so
  ``|std_delta / std_mc - 1| <= 0.03 + 1 / M_I``; a bias within 4 standard errors of the MC
  mean (4, not 3: about 30 comparisons, so that a 3-sigma MC fluctuation is not a failure)
  plus ``2 / M_I`` of itself (its own neglected third-order term). The width only where
  ``std(L) / L <= 0.35`` (L = ln(S / |R_1|)), where the module says the expansion holds;
* (b) the literature closed forms: where their assumptions hold (exact finite sums, large M,
  high SNR) they must agree with the delta method to the stated tolerance;
* (c) the dependence on the parameters: directions that the physics fixes.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from pasim_blocks.processing.pulse_pair import pulse_pair

from tests.reference import theory

C = 299_792_458.0
LAM = C / 2.8e9  # 2800 MHz
PRT = 1e-3
NYQUIST = LAM / (4 * PRT)
FIXED = {"velocity": 5.0, "zdr": 1.0, "phidp": 30.0}
# The validation grid: pulses, width (m/s), SNR (dB), rho_hv.
GRID = list(itertools.product([32, 128], [2.0, 4.0], [10.0, 30.0], [0.9, 0.98]))


def grid_args(pulses=None, width=None, snr=None, rho=None):
    """Arrays over GRID (or the scalars given) in estimator_statistics' argument order."""
    g = np.array(GRID)
    cols = [g[:, i] if x is None else x for i, x in enumerate((pulses, width, snr, rho))]
    m, w, s, r = cols
    return (m, PRT, LAM, w, FIXED["velocity"], s, FIXED["zdr"], r, FIXED["phidp"])


def joint_covariance(m, width, velocity, s_h, s_v, n_h, n_v, rho, phidp) -> np.ndarray:
    """Covariance E[z z^H] of z = (h_0..h_{M-1}, v_0..v_{M-1}) from the model's definition."""
    lag = np.arange(m)[:, None] - np.arange(m)[None, :]
    base = np.exp(-8 * (np.pi * width * lag * PRT / LAM) ** 2) * np.exp(
        -4j * np.pi * velocity * lag * PRT / LAM
    )  # E[x_i x_j^*] of a unit-power Gaussian-spectrum process
    sigma = np.zeros((2 * m, 2 * m), complex)
    sigma[:m, :m] = s_h * base + n_h * np.eye(m)
    sigma[m:, m:] = s_v * base + n_v * np.eye(m)
    sigma[m:, :m] = np.sqrt(s_h * s_v) * rho * np.exp(1j * np.deg2rad(phidp)) * base  # E[v h^*]
    sigma[:m, m:] = sigma[m:, :m].conj().T
    return sigma


def draw_iq(m, width, snr_db, rho, gates, seed) -> tuple[np.ndarray, np.ndarray, float]:
    """H and V I/Q of `gates` dwells (S_H = 1, same noise in V), and the noise power."""
    noise = 10 ** (-snr_db / 10)
    s_v = 10 ** (-FIXED["zdr"] / 10)
    sigma = joint_covariance(
        m, width, FIXED["velocity"], 1.0, s_v, noise, noise, rho, FIXED["phidp"]
    )
    chol = np.linalg.cholesky(sigma)
    rng = np.random.default_rng(seed)
    w = rng.standard_normal((gates, 2 * m)) + 1j * rng.standard_normal((gates, 2 * m))
    w /= np.sqrt(2)
    h = w[:, :m] @ chol[:m, :m].T
    v = w[:, :m] @ chol[m:, :m].T + w[:, m:] @ chol[m:, m:].T
    return h, v, noise


# ---- the exact moments and the derivatives ------------------------------------------------


@pytest.mark.parametrize(
    "params",
    [
        (12, 2.0, 5.0, 1.0, 0.7, 0.1, 0.15, 0.95, 200.0),
        (9, 6.0, -12.0, 2.0, 2.5, 1.0, 0.5, 0.6, 10.0),
    ],
)
def test_lag_sums_equal_brute_force_isserlis(params) -> None:
    """Mean and covariance of (P_H, P_V, Re/Im R_hv, Re/Im R_1) from the module's lag sums
    equal tr(A Sigma) and tr(A Sigma B Sigma) of the Hermitian forms (H and V noise differ)."""
    m, width, vel, s_h, s_v, n_h, n_v, rho, phi = params
    sigma = joint_covariance(m, width, vel, s_h, s_v, n_h, n_v, rho, phi)

    def form(pairs, scale):
        a = np.zeros((2 * m, 2 * m), complex)
        for i, j in pairs:
            a[i, j] = scale  # z^H A z = scale * sum z_i^* z_j
        return a

    p_h = form([(k, k) for k in range(m)], 1 / m)
    p_v = form([(m + k, m + k) for k in range(m)], 1 / m)
    r_hv = form([(k, m + k) for k in range(m)], 1 / m)
    r_1 = form([(k, k + 1) for k in range(m - 1)], 1 / (m - 1))
    forms = [p_h, p_v]
    for a in (r_hv, r_1):
        forms += [(a + a.conj().T) / 2, (a - a.conj().T) / 2j]  # Re and Im as Hermitian forms
    a_sigma = [a @ sigma for a in forms]
    mean = np.array([np.trace(x).real for x in a_sigma])
    cov = np.array([[np.trace(x @ y).real for y in a_sigma] for x in a_sigma])

    got_mean, got_cov = theory.sample_correlation_moments(m, PRT, LAM, *params[1:])
    np.testing.assert_allclose(got_mean, mean, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(got_cov, cov, rtol=1e-9, atol=1e-14 * np.abs(cov).max())


def test_jets_match_finite_differences() -> None:
    """Gradient and Hessian of every estimate agree with central differences of its value."""
    t0 = np.array([1.3, 0.8, 0.7, 0.4, 0.9, -0.5])
    noise_h, noise_v = 0.1, 0.12
    jets = theory.estimator_jets(t0, noise_h, noise_v, PRT, LAM)
    step = 1e-5
    eye = np.eye(6) * step

    def value(name, t):
        return theory.estimator_jets(t, noise_h, noise_v, PRT, LAM)[name][0]

    for name, (v0, grad, hess) in jets.items():
        num_grad = np.array([(value(name, t0 + e) - value(name, t0 - e)) / (2 * step) for e in eye])
        num_hess = np.array(
            [
                [
                    (
                        value(name, t0 + ei + ej)
                        - value(name, t0 + ei - ej)
                        - value(name, t0 - ei + ej)
                        + value(name, t0 - ei - ej)
                    )
                    / (4 * step**2)
                    for ej in eye
                ]
                for ei in eye
            ]
        )
        scale = max(1.0, abs(float(v0)))
        np.testing.assert_allclose(grad, num_grad, atol=1e-6 * scale, err_msg=name)
        np.testing.assert_allclose(hess, num_hess, atol=2e-3 * scale, err_msg=name)


def test_zeroth_order_is_the_truth() -> None:
    """The estimators at the exact mean of the sample correlations return the truth, so the
    delta method's bias is only its second-order term."""
    for m, w, snr, rho in GRID[:4]:
        s_v = 10 ** (-FIXED["zdr"] / 10)
        noise = 10 ** (-snr / 10)
        mean, _ = theory.sample_correlation_moments(
            m, PRT, LAM, w, 5.0, 1.0, s_v, noise, noise, rho, 30.0
        )
        jets = theory.estimator_jets(mean, noise, noise, PRT, LAM)
        truth = {"DBZH": 0.0, "VRADH": 5.0, "WRADH": w, "ZDR": 1.0, "RHOHV": rho, "PHIDP": 30.0}
        for name, expected in truth.items():
            assert float(jets[name][0]) == pytest.approx(expected, abs=1e-9), name


# ---- (a) the delta method against a Monte Carlo of the estimator ----------------------------

# (pulses, width, SNR, rho_hv) from across the validation grid; seeds differ so that the MC
# errors of different cases are independent.
MC_CASES = {
    "M128-w4-snr30-rho98": (128, 4.0, 30.0, 0.98),
    "M128-w2-snr10-rho90": (128, 2.0, 10.0, 0.90),
    "M128-w4-snr10-rho90": (128, 4.0, 10.0, 0.90),
    "M32-w4-snr10-rho98": (32, 4.0, 10.0, 0.98),
    "M32-w2-snr30-rho90": (32, 2.0, 30.0, 0.90),
}
N_GATES = 20_000


@pytest.mark.parametrize("case", sorted(MC_CASES))
def test_delta_method_agrees_with_monte_carlo(case: str) -> None:
    """Bias and std of the six moments over 20,000 dwells vs estimator_statistics."""
    m, width, snr, rho = MC_CASES[case]
    h, v, noise = draw_iq(m, width, snr, rho, N_GATES, seed=sum(map(ord, case)))
    est = pulse_pair(h, v, noise, noise, PRT, LAM)
    est["DBZH"] = 10 * np.log10(np.where(est["S_H"] > 0, est["S_H"], np.nan))
    args = (m, PRT, LAM, width, FIXED["velocity"], snr, FIXED["zdr"], rho, FIXED["phidp"])
    theory_stats = theory.estimator_statistics(*args)
    m_i = float(theory.independent_samples(m, PRT, LAM, width))
    width_ok = float(theory.width_log_ratio_cv(*args)) <= 0.35
    truth = {"DBZH": 0.0, "VRADH": FIXED["velocity"], "WRADH": width, "ZDR": FIXED["zdr"]}
    truth |= {"RHOHV": rho, "PHIDP": FIXED["phidp"]}
    checked = []
    for name in theory.MOMENTS:
        if name == "WRADH" and not width_ok:
            continue
        values = est[name][np.isfinite(est[name])]
        assert values.size > 0.99 * N_GATES, name  # masking is negligible here
        err = values - truth[name]
        if name == "PHIDP":  # reported in [0, 360): 30 deg -> errors below -30 wrap
            err = (err + 180.0) % 360.0 - 180.0
        elif name == "VRADH":  # folded into +-Nyquist, as the estimate is
            err = (err + NYQUIST) % (2 * NYQUIST) - NYQUIST
        bias_mc, std_mc = err.mean(), err.std(ddof=1)
        bias, std = (float(x) for x in theory_stats[name])
        assert std / std_mc == pytest.approx(1.0, abs=0.03 + 1 / m_i), (name, std, std_mc)
        allowance = 4 * std_mc / np.sqrt(values.size) + 2 / m_i * abs(bias)
        assert abs(bias_mc - bias) <= allowance, (name, bias, bias_mc, allowance)
        checked.append(name)
    assert len(checked) >= 5


def test_monte_carlo_reference_agrees_with_an_independent_draw() -> None:
    """monte_carlo_statistics (the module's fallback reference) matches the draw above where
    the delta method does not hold (narrow spectrum, low SNR, short dwell: width clipped)."""
    m, width, snr, rho = 32, 2.0, 10.0, 0.98
    ref = theory.monte_carlo_statistics(m, PRT, LAM, width, 5.0, snr, 1.0, rho, 30.0, seed=3)
    h, v, noise = draw_iq(m, width, snr, rho, N_GATES, seed=4)
    est = pulse_pair(h, v, noise, noise, PRT, LAM)
    for name in ("VRADH", "WRADH", "RHOHV"):
        values = est[name][np.isfinite(est[name])]
        truth = {"VRADH": 5.0, "WRADH": width, "RHOHV": rho}[name]
        se = values.std() / np.sqrt(values.size)
        assert ref[name][0] == pytest.approx(values.mean() - truth, abs=4 * np.sqrt(2) * se)
        assert ref[name][1] == pytest.approx(values.std(), rel=0.04)


# ---- (b) the closed forms where their assumptions hold --------------------------------------


def test_power_closed_form_with_finite_sum_is_the_delta_method() -> None:
    """D&Z's var(P) with the exact finite sum is exactly the first-order variance; its dB bias
    is the delta method's second-order one."""
    args = grid_args()
    delta = theory.estimator_statistics(*args)["DBZH"]
    bias, std = theory.power_statistics_dz(args[0], PRT, LAM, args[3], args[5], large_m=False)
    np.testing.assert_allclose(std, delta[1], rtol=1e-10)
    np.testing.assert_allclose(bias, delta[0], rtol=1e-10)


def test_zrnic_velocity_with_finite_sum_matches_delta_method() -> None:
    """Zrnic (1977) / D&Z (6.21) with the finite sum over M - 1 pairs: within 1 % over the
    grid (it differs only in O(1/M) end terms of the noise part)."""
    args = grid_args()
    delta = theory.estimator_statistics(*args)["VRADH"][1]
    got = theory.velocity_std_zrnic(args[0], PRT, LAM, args[3], args[5], large_m=False)
    np.testing.assert_allclose(got, delta, rtol=0.01)


def test_large_m_closed_forms_match_delta_method() -> None:
    """The large-M literature forms (dB power, velocity, Z_DR, rho_hv, phi_DP): within 5 %
    over the grid (the finite-M sum differs from 1 / (2 sqrt(pi) sigma_vn) by at most 8 % at
    M = 32, w = 2 m/s) and within 0.5 % at M = 2000; the Z_DR bias exactly, the rho_hv bias
    within 10 %."""
    for pulses, rtol in ((None, 0.05), (2000, 0.005)):
        args = grid_args(pulses=pulses)
        delta = theory.estimator_statistics(*args)
        closed = theory.closed_form_statistics(*args)
        for name in ("DBZH", "VRADH", "ZDR", "RHOHV", "PHIDP"):
            np.testing.assert_allclose(closed[name][1], delta[name][1], rtol=rtol, err_msg=name)
        np.testing.assert_allclose(closed["ZDR"][0], delta["ZDR"][0], rtol=1e-9)
        np.testing.assert_allclose(closed["RHOHV"][0], delta["RHOHV"][0], rtol=max(0.1, rtol))


def test_narrow_spectrum_velocity_limit() -> None:
    """D&Z (6.22), sigma_v lambda / (8 M T sqrt(pi)): within 6 % at SNR 30 dB on the grid
    (sigma_vn 0.04 to 0.07)."""
    args = grid_args(snr=30.0)
    delta = theory.estimator_statistics(*args)["VRADH"][1]
    got = theory.velocity_std_narrow(args[0], PRT, LAM, args[3])
    np.testing.assert_allclose(got, delta, rtol=0.06)


def test_width_closed_form_converges_to_delta_method() -> None:
    """The large-M width statistics: within 8 % at M = 128, w = 4 m/s; within 2 % (std) and 3 %
    (bias) at M = 4000. At w = 2 m/s and M <= 128 they are 12-56 % low: the leading signal
    terms cancel to O(a^2), so the O(1/M) end terms (M powers, M - 1 pairs) matter."""
    args = grid_args(pulses=128, width=4.0)
    d, c = (
        theory.estimator_statistics(*args)["WRADH"],
        theory.width_statistics(128, PRT, LAM, 4.0, args[5]),
    )
    np.testing.assert_allclose(c[1], d[1], rtol=0.08)
    args = grid_args(pulses=4000)
    d = theory.estimator_statistics(*args)["WRADH"]
    c = theory.width_statistics(4000, PRT, LAM, args[3], args[5])
    np.testing.assert_allclose(c[1], d[1], rtol=0.02)
    np.testing.assert_allclose(c[0], d[0], rtol=0.03)


# ---- (c) dependence on the parameters --------------------------------------------------------


def test_velocity_std_grows_as_snr_drops_and_width_grows() -> None:
    snr = np.array([40.0, 30.0, 20.0, 10.0, 5.0, 0.0])
    std = theory.estimator_statistics(64, PRT, LAM, 3.0, 5.0, snr, 1.0, 0.95, 30.0)["VRADH"][1]
    assert np.all(np.diff(std) > 0)
    width = np.array([1.0, 2.0, 4.0, 6.0])
    std = theory.estimator_statistics(64, PRT, LAM, width, 5.0, 20.0, 1.0, 0.95, 30.0)["VRADH"][1]
    assert np.all(np.diff(std) > 0)


def test_polarimetric_std_falls_as_rho_tends_to_one() -> None:
    rho = np.array([0.5, 0.8, 0.9, 0.95, 0.98, 0.99, 0.999])
    stats = theory.estimator_statistics(64, PRT, LAM, 3.0, 5.0, 30.0, 1.0, rho, 30.0)
    for name in ("RHOHV", "ZDR", "PHIDP"):
        assert np.all(np.diff(stats[name][1]) < 0), name
    # Noise-free and rho -> 1: rho_hv and phi_DP become exact; with noise they do not.
    clean = theory.estimator_statistics(64, PRT, LAM, 3.0, 5.0, 200.0, 0.0, 1 - 1e-6, 30.0)
    assert clean["RHOHV"][1] < 1e-5 and clean["PHIDP"][1] < 0.05
    assert stats["RHOHV"][1][-1] > 1e-4


def test_std_scales_as_inverse_root_of_dwell() -> None:
    """Quadrupling a long dwell halves every std: within 2 %, the width within 5 % (its
    O(1/M) end terms are relatively large, see the width closed-form test)."""
    stats = theory.estimator_statistics(
        np.array([256, 1024]), PRT, LAM, 4.0, 5.0, 20.0, 1.0, 0.95, 30.0
    )
    for name in theory.MOMENTS:
        ratio = stats[name][1][1] / stats[name][1][0]
        assert ratio == pytest.approx(0.5, rel=0.05 if name == "WRADH" else 0.02), name


def test_biases_have_the_expected_signs() -> None:
    """dB power is biased low (Jensen); Z_DR high (V is the noisier channel) and unbiased
    without noise; rho_hv high at finite M; width low; velocity and phi_DP unbiased."""
    snr = np.array([10.0, 30.0, 300.0])
    stats = theory.estimator_statistics(32, PRT, LAM, 4.0, 5.0, snr, 1.0, 0.9, 30.0)
    assert np.all(stats["DBZH"][0] < 0)
    assert np.all(stats["ZDR"][0][:2] > 0) and abs(stats["ZDR"][0][2]) < 1e-12
    assert np.all(stats["RHOHV"][0] > 0)
    assert np.all(stats["WRADH"][0] < 0)
    np.testing.assert_allclose(stats["VRADH"][0], 0.0, atol=1e-9)
    np.testing.assert_allclose(stats["PHIDP"][0], 0.0, atol=1e-9)


def test_no_dependence_on_velocity_or_phidp_and_broadcasting() -> None:
    """Without aliasing the statistics do not depend on velocity or phi_DP (the phases only
    rotate R_1 and R_hv); an array call equals the scalar calls."""
    base = theory.estimator_statistics(32, PRT, LAM, 3.0, 5.0, 20.0, 1.0, 0.95, 30.0)
    moved = theory.estimator_statistics(32, PRT, LAM, 3.0, -20.0, 20.0, 1.0, 0.95, 250.0)
    for name in theory.MOMENTS:
        assert moved[name][0] == pytest.approx(base[name][0], abs=1e-9)
        assert moved[name][1] == pytest.approx(base[name][1], rel=1e-9)
    args = grid_args()
    vec = theory.estimator_statistics(*args)
    for i, (m, w, snr, rho) in enumerate(GRID):
        one = theory.estimator_statistics(m, PRT, LAM, w, 5.0, snr, 1.0, rho, 30.0)
        for name in theory.MOMENTS:
            assert vec[name][1][i] == pytest.approx(float(one[name][1]), rel=1e-12)
