"""Tests of pulse-pair processing (``blocks/ppp.py``: ``pulse_pair`` and ``PulsePairProcessor``).

What each test compares against:

* statistics over many gates: dual-polarisation I/Q drawn here, independently of the
  simulator's weather channel, by Cholesky colouring with numpy of a Gaussian-spectrum
  process (known power, mean velocity, spectrum width) and a V channel with known ZDR, rho_hv
  and phi_DP, plus white noise of known power. The truth is what went in. The expected mean
  and standard deviation of every estimate come from ``tests.reference.theory``: the second-order
  delta method on the exact second moments (Isserlis' theorem) of the lag-0, lag-1 and H-V
  sample correlations (itself tested against brute-force traces and a Monte Carlo in
  ``test_theory.py``). Its first-order variance is the perturbation result of Doviak & Zrnic
  (and of Melnikov & Zrnic for the polarimetric moments); its second-order term is the
  finite-dwell bias (e.g. about -0.01 m/s of spectrum width at M = 64), so the comparison
  with truth does not need a hand-tuned allowance;
* velocity sign and aliasing: a pure tone with the documented convention (positive away =
  lag-1 phase negative, v = -lambda / (4 pi T) arg R1);
* width: the Gaussian-spectrum relation R1 = S exp(-8 (pi w T / lambda)^2), inverted;
* masking, rho_hv > 1 and the phi_DP range: the estimator definitions on hand-made I/Q;
* the block: DBZH = 10 log10(S) + 20 log10(r) - C_H, ZDR corrected by C_H - C_V (the radar
  equation), Nyquist velocity lambda / (4 T);
* alternate transmission (AHV): the estimators of Zrnic (1991) on the exact correlations of
  a Gaussian-spectrum echo return its moments exactly; on AHV I/Q drawn here their means
  agree with the truth (5 empirical standard errors plus a stated finite-dwell allowance);
  the block's Nyquist velocity is lambda / (8 T), phi_DP modulo 180; in SHV the transmit
  differential phase is removed from phi_DP.

Statistical tolerance: the mean over n gates of an estimate with standard deviation sigma
has standard error sigma / sqrt(n), sigma from the theory above; means must agree within 5
standard errors. The empirical standard deviation must match the theoretical one within 10 %:
its own sampling error is about 1/sqrt(2 n) = 1.1 % for n = 4000 (a bit more for the
heavier-tailed power estimate), and the delta method neglects O(1/M) terms of a few percent.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.processing.pulse_pair import PulsePairProcessor, pulse_pair
from pasim_blocks.scans.ppi import PPISector

from pasim_graph import Chunk
from tests.reference.theory import pulse_pair_statistics

C = 299_792_458.0
WAVELENGTH_M = C / 2.8e9  # paper Table 4: 2800 MHz
PRT_S = 1 / 300  # paper Table 4: PRF 300 Hz
M = 64  # pulses per dwell
N_GATES = 4000
K_VEL = WAVELENGTH_M / (4 * np.pi * PRT_S)
NYQUIST = WAVELENGTH_M / (4 * PRT_S)


def normalised_covariance(velocity: float, width: float) -> np.ndarray:
    """C[m, n] = E[x_m x_n^*] of a unit-power Gaussian-spectrum process (paper eq. 13 without
    noise): rho(m - n) exp(-j 4 pi v (m - n) T / lambda), rho(k) = exp(-8 (pi w k T/lambda)^2).
    """
    lag = np.arange(M)[:, None] - np.arange(M)[None, :]
    rho = np.exp(-8 * (np.pi * width * lag * PRT_S / WAVELENGTH_M) ** 2)
    return rho * np.exp(-4j * np.pi * velocity * lag * PRT_S / WAVELENGTH_M)


def simulate(truth: dict, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Draw H and V I/Q (n gates x M pulses)."""
    rng = np.random.default_rng(seed)
    chol = np.linalg.cholesky(normalised_covariance(truth["v"], truth["w"]))

    def white(shape: tuple[int, ...]) -> np.ndarray:
        return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)

    x1 = white((n, M)) @ chol.T
    x2 = white((n, M)) @ chol.T
    s_h = truth["S_H"]
    s_v = s_h / 10 ** (truth["ZDR"] / 10)
    rho, phi = truth["RHOHV"], np.deg2rad(truth["PHIDP"])
    h = np.sqrt(s_h) * x1 + np.sqrt(truth["N_H"]) * white((n, M))
    v = np.sqrt(s_v) * (rho * x1 + np.sqrt(1 - rho**2) * x2) * np.exp(1j * phi)
    v = v + np.sqrt(truth["N_V"]) * white((n, M))
    return h, v


def theory_statistics(truth: dict) -> dict[str, tuple[float, float]]:
    """Expected value (second order) and std (first order) of every estimate for `truth`."""
    stats = pulse_pair_statistics(
        M,
        PRT_S,
        WAVELENGTH_M,
        truth["w"],
        truth["v"],
        truth["S_H"],
        truth["S_H"] / 10 ** (truth["ZDR"] / 10),
        truth["N_H"],
        truth["N_V"],
        truth["RHOHV"],
        truth["PHIDP"],
    )
    return {k: (float(mean), float(sd)) for k, (mean, sd) in stats.items()}


CASES = {
    # High SNR (20 dB), equal noise in both channels.
    "snr20": {
        "S_H": 1.0, "v": 5.0, "w": 2.0, "ZDR": 1.5, "RHOHV": 0.98, "PHIDP": 200.0,
        "N_H": 0.01, "N_V": 0.01,
    },
    # Low SNR (8 dB in H), approaching and wider, V noise 1.5 x H noise, negative ZDR. (At
    # 5 dB and 3 m/s the velocity errors grow tails the first-order theory does not follow.)
    "snr8": {
        "S_H": 2.0, "v": -6.0, "w": 2.5, "ZDR": -0.5, "RHOHV": 0.95, "PHIDP": 45.0,
        "N_H": 2.0 / 10**0.8, "N_V": 1.5 * 2.0 / 10**0.8,
    },
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(CASES))
def test_moments_agree_with_truth_and_theory(case: str) -> None:
    """Mean and standard deviation of every moment over 4000 gates vs the truth and theory."""
    truth = CASES[case]
    h, v = simulate(truth, N_GATES, seed=20240 + len(case))
    est = pulse_pair(h, v, truth["N_H"], truth["N_V"], PRT_S, WAVELENGTH_M)
    theory = theory_statistics(truth)
    expected_truth = {
        "S_H": truth["S_H"],
        "S_V": truth["S_H"] / 10 ** (truth["ZDR"] / 10),
        "ZDR": truth["ZDR"],
        "RHOHV": truth["RHOHV"],
        "PHIDP": truth["PHIDP"],
        "VRADH": truth["v"],
        "WRADH": truth["w"],
    }
    for name in expected_truth:
        values = np.asarray(est[name], dtype=np.float64)
        assert np.all(np.isfinite(values)), f"{name}: unexpected NaN"
        predicted_mean, sd = theory[name]
        se = sd / np.sqrt(values.size)
        assert abs(values.mean() - predicted_mean) <= 5 * se, (
            f"{name}: mean {values.mean():.5g}, truth {expected_truth[name]:.5g}, "
            f"theory {predicted_mean:.5g} +- {se:.2g}"
        )
        assert values.std(ddof=1) == pytest.approx(sd, rel=0.10), name


@pytest.mark.parametrize("velocity", [-7.5, -3.0, -0.2, 0.0, 0.4, 2.5, 7.9])
def test_velocity_sign_convention(velocity: float) -> None:
    """Positive velocity = away from the radar = negative lag-1 phase: a noise-free tone
    x_m = exp(-j 4 pi v m T / lambda) gives back v inside +-Nyquist, and its width is 0."""
    m = np.arange(M)
    x = np.exp(-4j * np.pi * velocity * m * PRT_S / WAVELENGTH_M)[None, :]
    est = pulse_pair(x, x, 0.0, 0.0, PRT_S, WAVELENGTH_M)
    assert est["VRADH"][0] == pytest.approx(velocity, abs=1e-9)
    r1 = np.mean(np.conj(x[0, :-1]) * x[0, 1:])
    assert np.sign(np.angle(r1)) == -np.sign(velocity)
    assert est["WRADH"][0] == pytest.approx(0.0, abs=1e-6)


def test_velocity_aliases_beyond_nyquist() -> None:
    """A tone at v_a + 1 m/s folds to -v_a + 1 m/s (v_a = lambda / (4 T), 8.03 m/s here)."""
    m = np.arange(M)
    v_true = NYQUIST + 1.0
    x = np.exp(-4j * np.pi * v_true * m * PRT_S / WAVELENGTH_M)[None, :]
    est = pulse_pair(x, x, 0.0, 0.0, PRT_S, WAVELENGTH_M)
    assert est["VRADH"][0] == pytest.approx(v_true - 2 * NYQUIST, abs=1e-9)


@pytest.mark.parametrize("width", [0.5, 1.0, 4.0])
def test_width_inverts_gaussian_spectrum_relation(width: float) -> None:
    """Two-pulse dwell x = (1, b e^{j theta}): S = (1 + b^2)/2, |R1| = b. With b chosen so that
    S/|R1| = exp(8 (pi w T / lambda)^2) (the Gaussian-spectrum relation), the width is w."""
    ratio = np.exp(8 * (np.pi * width * PRT_S / WAVELENGTH_M) ** 2)
    b = ratio - np.sqrt(ratio**2 - 1)  # root of (1 + b^2) / (2 b) = ratio
    x = np.array([[1.0, b * np.exp(-0.3j)]])
    est = pulse_pair(x, x, 0.0, 0.0, PRT_S, WAVELENGTH_M)
    assert est["WRADH"][0] == pytest.approx(width, rel=1e-9)
    assert est["VRADH"][0] == pytest.approx(K_VEL * 0.3, rel=1e-9)


def test_masking_where_corrected_power_is_not_positive() -> None:
    """S_H <= 0 masks every moment; S_V <= 0 (S_H > 0) masks the polarimetric ones. NaN, no
    warnings (they are turned into errors here) and no exception."""
    rng = np.random.default_rng(9)
    shape = (3, M)
    h = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)  # power about 2
    v = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    h[1] *= 10.0  # gate 1: strong H, weak V -> S_V <= 0 only
    h[2] = 0.0  # gate 2: nothing at all, S = -noise
    v[2] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        est = pulse_pair(h, v, 50.0, 50.0, PRT_S, WAVELENGTH_M)
    assert est["S_H"][0] < 0 and est["S_H"][2] < 0 and est["S_H"][1] > 0
    for name in ("VRADH", "WRADH", "ZDR", "RHOHV", "PHIDP"):
        assert np.isnan(est[name][0]), name
        assert np.isnan(est[name][2]), name
    assert np.isfinite(est["VRADH"][1]) and np.isfinite(est["WRADH"][1])
    for name in ("ZDR", "RHOHV", "PHIDP"):
        assert np.isnan(est[name][1]), name


def test_rho_hv_above_one_is_kept() -> None:
    """Identical H and V with the noise over-estimated: rho = P / (P - N) > 1, not clipped."""
    rng = np.random.default_rng(4)
    x = rng.standard_normal((5, M)) + 1j * rng.standard_normal((5, M))
    p = np.mean(np.abs(x) ** 2, axis=-1)
    noise = 0.2
    est = pulse_pair(x, x, noise, noise, PRT_S, WAVELENGTH_M)
    np.testing.assert_allclose(est["RHOHV"], p / (p - noise), rtol=1e-12)
    assert np.all(est["RHOHV"] > 1)


def test_phidp_is_in_0_360() -> None:
    """phi_DP is reported in [0, 360): a deterministic -10 deg gives 350; a noisy 1 deg
    straddles 0/360 yet every value stays in range and the circular mean is 1 deg within 5
    standard errors (delta-method standard deviation, as above)."""
    x = np.ones((1, M), complex)
    est = pulse_pair(x, x * np.exp(-1j * np.deg2rad(10.0)), 0.0, 0.0, PRT_S, WAVELENGTH_M)
    assert est["PHIDP"][0] == pytest.approx(350.0, abs=1e-9)

    truth = {**CASES["snr8"], "PHIDP": 1.0}
    h, v = simulate(truth, N_GATES, seed=77)
    phidp = pulse_pair(h, v, truth["N_H"], truth["N_V"], PRT_S, WAVELENGTH_M)["PHIDP"]
    assert np.all((phidp >= 0) & (phidp < 360))
    assert np.any(phidp > 350) and np.any(phidp < 10)  # the estimates do straddle 0
    circ_mean = np.rad2deg(np.angle(np.mean(np.exp(1j * np.deg2rad(phidp)))))
    _, sd = theory_statistics(truth)["PHIDP"]
    assert circ_mean == pytest.approx(1.0, abs=5 * sd / np.sqrt(N_GATES))


# ---- the block --------------------------------------------------------------------------------


def block_inputs(n_beams: int = 2, n_gates: int = 6):
    """Noise-free tones of chosen amplitudes, so every estimate is known in closed form."""
    beams = PPISector(name="scan", prt_s=PRT_S, pulses=M).process(
        {}, Chunk(beams=np.arange(n_beams))
    )["beams"]
    rng_m = np.linspace(2_000.0, 120_000.0, n_gates)
    const = np.array([[-70.0, -70.4], [-71.5, -71.2]])[:n_beams]  # dB, H and V per beam
    calibration = xr.Dataset(
        {"radar_constant_db": (("beam", "polarization"), const)},
        coords={"range": ("range", rng_m), "polarization": ["H", "V"]},
        attrs={
            "wavelength_m": WAVELENGTH_M,
            "prt_s": PRT_S,
            "blind_range_m": 0.0,
            "calibration": "boresight",
        },
    )
    amp_h = np.linspace(1e-4, 1e-2, n_beams * n_gates).reshape(n_beams, n_gates)
    amp_v = 0.8 * amp_h
    velocity, phidp = 3.0, 30.0
    m = np.arange(M)
    tone = np.exp(-4j * np.pi * velocity * m * PRT_S / WAVELENGTH_M)
    iq = np.zeros((n_beams, n_gates, M, 2), np.complex64)
    iq[..., 0] = amp_h[..., None] * tone
    iq[..., 1] = amp_v[..., None] * tone * np.exp(1j * np.deg2rad(phidp))
    noise = np.array([1e-9, 2e-9])
    inputs = {"iq": iq, "noise_power": noise, "calibration": calibration, "beams": beams}
    return inputs, amp_h, amp_v, velocity, phidp


def test_block_dbz_zdr_and_calibration() -> None:
    """DBZH = 10 log10(S_H) + 20 log10(r) - C_H; ZDR = 10 log10(S_H / S_V) - (C_H - C_V);
    S = |amplitude|^2 - noise of that channel (noise-free tone); velocity, phi_DP and rho of
    the tone; the Nyquist velocity lambda / (4 T)."""
    inputs, amp_h, amp_v, velocity, phidp = block_inputs()
    out = PulsePairProcessor(name="ppp").process(inputs, Chunk(beams=np.arange(2)))["moments"]
    const = inputs["calibration"]["radar_constant_db"].values
    rng_m = inputs["calibration"]["range"].values
    s_h = amp_h**2 - inputs["noise_power"][0]
    s_v = amp_v**2 - inputs["noise_power"][1]
    dbz = 10 * np.log10(s_h) + 20 * np.log10(rng_m)[None, :] - const[:, :1]
    zdr = 10 * np.log10(s_h / s_v) - (const[:, :1] - const[:, 1:])
    np.testing.assert_allclose(out["DBZH"].values, dbz, atol=1e-3)
    np.testing.assert_allclose(out["ZDR"].values, zdr, atol=1e-3)
    np.testing.assert_allclose(out["VRADH"].values, velocity, atol=1e-4)
    np.testing.assert_allclose(out["PHIDP"].values, phidp, atol=1e-3)
    np.testing.assert_allclose(out["RHOHV"].values, amp_h * amp_v / np.sqrt(s_h * s_v), rtol=1e-4)
    np.testing.assert_allclose(out["WRADH"].values, 0.0, atol=0.05)
    np.testing.assert_allclose(out["nyquist_velocity"].values, WAVELENGTH_M / (4 * PRT_S))
    for name in ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"):
        assert out[name].dims == ("beam", "range")
        assert out[name].dtype == np.float32
    assert out["DBZH"].attrs["units"] == "dBZ"
    np.testing.assert_array_equal(out["range"].values, rng_m)


@pytest.mark.parametrize("code", ["sz8_64", "random"])
def test_block_coheres_a_phase_coded_dwell_to_the_first_trip(code: str) -> None:
    """A first-trip echo of a phase-coded scan carries each pulse's transmit phase psi_m; the
    processor multiplies by e^(-j psi_m) first, so the coded tones give the uncoded tones'
    moments (velocity 3 m/s, width 0, phi_DP 30 deg; without it SZ(8/64)'s quadratic phase
    moves the lag-1 phase and spreads the tone)."""
    inputs, _, _, velocity, phidp = block_inputs()
    plain = PulsePairProcessor(name="ppp").process(inputs, Chunk(beams=np.arange(2)))["moments"]
    chunk = Chunk(beams=np.arange(2), seed=5)
    beams = PPISector(name="scan", prt_s=PRT_S, pulses=M, phase_code=code).process({}, chunk)
    psi = beams["beams"]["transmit_phase"].values  # beam x pulse
    coded = {**inputs, "beams": beams["beams"]}
    coded["iq"] = (inputs["iq"] * np.exp(1j * psi)[:, None, :, None]).astype(np.complex64)
    received = coded["iq"].copy()
    out = PulsePairProcessor(name="ppp").process(coded, chunk)["moments"]
    np.testing.assert_array_equal(coded["iq"], received)  # the input is not changed
    np.testing.assert_allclose(out["VRADH"].values, velocity, atol=1e-4)
    np.testing.assert_allclose(out["WRADH"].values, 0.0, atol=0.05)
    np.testing.assert_allclose(out["PHIDP"].values, phidp, atol=1e-3)
    for name in ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"):
        np.testing.assert_allclose(out[name].values, plain[name].values, atol=1e-3)


def test_block_masks_noise_only_gates() -> None:
    """A gate whose power does not exceed the noise gives NaN DBZH (and the other moments),
    with no warning."""
    inputs, *_ = block_inputs()
    inputs["iq"][0, 2] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = PulsePairProcessor(name="ppp").process(inputs, Chunk(beams=np.arange(2)))
    moments = out["moments"]
    for name in ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"):
        assert np.isnan(moments[name].values[0, 2]), name
        assert np.isfinite(moments[name].values[1, 2]), name


# ---- alternate transmission (AHV) -------------------------------------------------------------


def ahv_iq(truth: dict, n: int, pulses: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """AHV I/Q drawn here: the co-polar H and V processes at every pulse time (Cholesky
    colouring, as :func:`simulate`), kept on their own pulses (H on even, V on odd); the
    other port of each pulse receives noise only (no cross-polar field)."""
    rng = np.random.default_rng(seed)
    lag = np.arange(pulses)[:, None] - np.arange(pulses)[None, :]
    cov = np.exp(-8 * (np.pi * truth["w"] * lag * PRT_S / WAVELENGTH_M) ** 2) * np.exp(
        -4j * np.pi * truth["v"] * lag * PRT_S / WAVELENGTH_M
    )
    chol = np.linalg.cholesky(cov + 1e-9 * np.eye(pulses))

    def white(shape: tuple[int, ...]) -> np.ndarray:
        return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)

    x1, x2 = white((n, pulses)) @ chol.T, white((n, pulses)) @ chol.T
    s_v = truth["S_H"] / 10 ** (truth["ZDR"] / 10)
    rho, phi = truth["RHOHV"], np.deg2rad(truth["PHIDP"])
    h = np.sqrt(truth["S_H"]) * x1
    v = np.sqrt(s_v) * (rho * x1 + np.sqrt(1 - rho**2) * x2) * np.exp(1j * phi)
    h[:, 1::2] = 0
    v[:, 0::2] = 0
    return h + np.sqrt(truth["N_H"]) * white((n, pulses)), v + np.sqrt(truth["N_V"]) * white(
        (n, pulses)
    )


def fold(velocity: float, nyquist: float) -> float:
    return (velocity + nyquist) % (2 * nyquist) - nyquist


def test_alternate_estimators_on_exact_correlations() -> None:
    """The AHV estimators (Zrnic 1991) on the exact correlations of one Gaussian-spectrum echo
    give its moments back: R0 = S, R2 = S r(2), R1_HV = rho sqrt(S_h S_v) e^{j phi} r(1),
    R1_VH = its conjugate pair times r(1), with r(l) = exp(-8 (pi w l T / lambda)^2)
    exp(-j 4 pi v l T / lambda). Velocity folds into the halved Nyquist interval lambda/(8T);
    phi_DP comes modulo 180 deg."""
    from pasim_blocks.processing.pulse_pair import alternate_moments

    for v, w, phi in ((3.0, 2.0, 30.0), (5.0, 1.0, 250.0), (-1.5, 3.5, 120.0)):
        s_h, zdr, rho = 2.0, 1.7, 0.97
        s_v = s_h / 10 ** (zdr / 10)

        def r(lag: int, w: float = w, v: float = v) -> complex:
            a = np.pi * lag * PRT_S / WAVELENGTH_M
            return np.exp(-8 * (a * w) ** 2) * np.exp(-4j * a * v)

        x = rho * np.sqrt(s_h * s_v) * np.exp(1j * np.deg2rad(phi))  # E[h* v]
        corr = {
            "R0_H": np.array([s_h]),
            "R0_V": np.array([s_v]),
            "R2_H": np.array([s_h * r(2)]),
            "R2_V": np.array([s_v * r(2)]),
            "R1_HV": np.array([x * r(1)]),
            "R1_VH": np.array([np.conj(x) * r(1)]),
        }
        est = alternate_moments(corr, 0.0, 0.0, PRT_S, WAVELENGTH_M)
        assert est["VRADH"][0] == pytest.approx(fold(v, NYQUIST / 2), abs=1e-9)
        assert est["WRADH"][0] == pytest.approx(w, rel=1e-9)
        assert est["ZDR"][0] == pytest.approx(zdr, abs=1e-9)
        assert est["RHOHV"][0] == pytest.approx(rho, rel=1e-9)
        assert est["PHIDP"][0] == pytest.approx(phi % 180, abs=1e-9)


def test_alternate_estimators_on_drawn_iq() -> None:
    """AHV I/Q drawn here (4000 gates, 128 pulses: 64 of each polarisation, 20 dB SNR):
    the means of ZDR, rho_hv, phi_DP (mod 180), velocity (folded to lambda/(8T)) and width
    over the gates agree with the truth within 5 standard errors (empirical, from the spread)
    plus a finite-dwell allowance of 1 % of the width and 0.003 of rho_hv (estimators of
    ratios of sample correlations are biased at order 1/M)."""
    from pasim_blocks.processing.pulse_pair import alternate_correlations, alternate_moments

    truth = {**CASES["snr20"], "PHIDP": 100.0}
    h, v = ahv_iq(truth, N_GATES, 128, seed=31)
    est = alternate_moments(
        alternate_correlations(h, v), truth["N_H"], truth["N_V"], PRT_S, WAVELENGTH_M
    )
    n = h.shape[0]

    def check(name: str, value: np.ndarray, target: float, allowance: float = 0.0) -> None:
        se = np.std(value) / np.sqrt(n)
        assert abs(np.mean(value) - target) <= 5 * se + allowance, (name, np.mean(value), target)

    check("ZDR", est["ZDR"], truth["ZDR"])
    check("RHOHV", est["RHOHV"], truth["RHOHV"], 0.003)
    check("WRADH", est["WRADH"], truth["w"], 0.01 * truth["w"])
    # circular quantities: deviations from the truth on their own circles
    dv = (est["VRADH"] - fold(truth["v"], NYQUIST / 2) + NYQUIST / 2) % NYQUIST - NYQUIST / 2
    check("VRADH", dv, 0.0)
    dphi = (est["PHIDP"] - truth["PHIDP"] % 180 + 90) % 180 - 90
    check("PHIDP", dphi, 0.0)
    assert np.all((est["PHIDP"] >= 0) & (est["PHIDP"] < 180))


def test_block_alternate_and_transmit_phase() -> None:
    """The processor reads the transmission from the calibration: AHV halves the Nyquist
    velocity (lambda / (8T)), reports phi_DP modulo 180 and says so (``phidp_period_deg``),
    and takes DBZH and ZDR from the co-polar pulses (radar equation as in SHV); in SHV the
    transmit differential phase beta is removed from phi_DP."""
    inputs, amp_h, amp_v, velocity, phidp = block_inputs()
    beta = 40.0
    shifted = {**inputs, "iq": inputs["iq"].copy()}
    shifted["iq"][..., 1] *= np.exp(1j * np.deg2rad(beta))
    shifted["calibration"] = inputs["calibration"].assign_attrs(
        transmission="shv", transmit_differential_phase_deg=beta
    )
    out = PulsePairProcessor(name="ppp").process(shifted, Chunk(beams=np.arange(2)))["moments"]
    np.testing.assert_allclose(out["PHIDP"].values, phidp, atol=1e-3)
    assert out.attrs["phidp_period_deg"] == 360.0
    ahv = {**inputs, "iq": inputs["iq"].copy()}
    ahv["iq"][:, :, 1::2, 0] = 0  # H port on V pulses: no cross-polar echo
    ahv["iq"][:, :, 0::2, 1] = 0
    ahv["calibration"] = inputs["calibration"].assign_attrs(transmission="ahv")
    out = PulsePairProcessor(name="ppp").process(ahv, Chunk(beams=np.arange(2)))["moments"]
    np.testing.assert_allclose(out["nyquist_velocity"].values, WAVELENGTH_M / (8 * PRT_S))
    np.testing.assert_allclose(out["VRADH"].values, fold(velocity, NYQUIST / 2), atol=1e-4)
    np.testing.assert_allclose(out["PHIDP"].values, phidp % 180, atol=1e-3)
    # DBZH and ZDR from the co-polar pulses (H on even, V on odd) and the radar equation.
    const = inputs["calibration"]["radar_constant_db"].values
    s_h = amp_h**2 - inputs["noise_power"][0]
    s_v = amp_v**2 - inputs["noise_power"][1]
    rng_m = inputs["calibration"]["range"].values
    dbz = 10 * np.log10(s_h) + 20 * np.log10(rng_m)[None, :] - const[:, :1]
    np.testing.assert_allclose(out["DBZH"].values, dbz, atol=1e-3)
    zdr = 10 * np.log10(s_h / s_v) - (const[:, :1] - const[:, 1:])
    np.testing.assert_allclose(out["ZDR"].values, zdr, atol=1e-3)
    assert out.attrs["phidp_period_deg"] == 180.0 and out.attrs["transmission"] == "ahv"
