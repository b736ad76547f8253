"""Drop size distributions at the monte_carlo level (:mod:`pasim_blocks.weather.dsd`).

The references are independent of the module: the depolarisation factors by numerical
integration of the ellipsoid integral (not the closed form), the distribution's moments by
adaptive quadrature (scipy.integrate.quad) of Rayleigh amplitudes written out here, and the
water permittivity against handbook values.
"""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.signals import KW2, SPEED_OF_LIGHT
from pasim_blocks.weather import dsd
from pasim_blocks.weather.channel import WeatherChannel
from scipy import integrate, optimize

from pasim_graph import Chunk

from .test_block_weather import chain_inputs, uniform_truth

FREQUENCY = 2.8e9
LAM = SPEED_OF_LIGHT / FREQUENCY


def depolarisation_by_integral(ratio: float) -> tuple[float, float]:
    """L_i = (a b c / 2) int_0^inf ds / ((s + a_i^2) sqrt((s + a^2)(s + b^2)(s + c^2)))."""
    a = b = 1.0
    c = ratio

    def factor(ai: float) -> float:
        def f(s: float) -> float:
            return 1 / ((s + ai**2) * np.sqrt((s + a**2) * (s + b**2) * (s + c**2)))

        return a * b * c / 2 * integrate.quad(f, 0, np.inf, epsabs=0, epsrel=1e-10)[0]

    return factor(a), factor(c)


def brandes(d_mm: float) -> float:
    return min(
        1.0, 0.9951 + 0.0251 * d_mm - 0.03644 * d_mm**2 + 5.303e-3 * d_mm**3 - 2.492e-4 * d_mm**4
    )


def reference_moments(lam: float, eps: complex) -> dict[str, float]:
    """ZDR, rho_hv and KDP per Z of the constrained gamma with this Lambda, by quadrature."""
    mu = -0.016 * min(lam, 1.213 / 0.032) ** 2 + 1.213 * min(lam, 1.213 / 0.032) - 1.957
    k = 2 * np.pi / LAM

    def alpha(d_mm: float) -> tuple[complex, complex]:
        l_h, l_v = depolarisation_by_integral(brandes(d_mm))
        volume = np.pi * (d_mm * 1e-3) ** 3 / 6
        return tuple(
            k**2 / (4 * np.pi) * volume * (eps - 1) / (1 + li * (eps - 1)) for li in (l_h, l_v)
        )

    def moment(g) -> float:
        def f(d: float) -> float:
            return g(*alpha(d)) * d**mu * np.exp(-lam * d)

        return integrate.quad(f, 0, dsd.D_MAX_MM, limit=200, epsrel=1e-9)[0]

    zh = moment(lambda h, v: abs(h) ** 2)
    zv = moment(lambda h, v: abs(v) ** 2)
    xr = moment(lambda h, v: (h * np.conj(v)).real)
    xi = moment(lambda h, v: (h * np.conj(v)).imag)
    kd = moment(lambda h, v: (h - v).real)
    z_factor = 4 * np.pi * LAM**4 / (np.pi**5 * KW2) * 1e18
    return {
        "zdr_db": 10 * np.log10(zh / zv),
        "rho_hv": abs(complex(xr, xi)) / np.sqrt(zh * zv),
        # deg/km for Z = 1 mm^6 m^-3
        "kdp_per_z": (180 / np.pi) * LAM * kd * 1e3 / (z_factor * zh),
    }


def test_water_permittivity_against_handbook_values():
    """Static permittivity of water at 20 C is 80.1 (CRC handbook); |K_w|^2 at S band from 0 to
    20 C lies within 0.01 of the 0.93 radars use."""
    assert dsd.water_permittivity(0.0, 20.0).real == pytest.approx(80.1, abs=0.2)
    for t in (0.0, 10.0, 20.0):
        eps = dsd.water_permittivity(FREQUENCY, t)
        assert abs(abs((eps - 1) / (eps + 2)) ** 2 - 0.93) < 0.01


@pytest.mark.parametrize("ratio", [1.0, 0.95, 0.7, 0.5])
def test_depolarisation_factors_against_the_ellipsoid_integral(ratio):
    """Closed-form oblate factors against the numerical integral (sum 1, sphere 1/3)."""
    l_h, l_v = dsd.depolarisation(np.array(ratio))
    ref_h, ref_v = depolarisation_by_integral(ratio)
    assert float(l_h) == pytest.approx(ref_h, rel=1e-6)
    assert float(l_v) == pytest.approx(ref_v, rel=1e-6)


@pytest.mark.parametrize("zdr_db", [0.5, 1.5, 3.0])
def test_fitted_distribution_against_quadrature(zdr_db):
    """The fit's ZDR, rho_hv and KDP against adaptive quadrature at the fitted Lambda, and
    the fitted Lambda against an independent root-find of the quadrature's ZDR."""
    sizes = dsd.DropSizes.build(FREQUENCY, 10.0)
    eps = dsd.water_permittivity(FREQUENCY, 10.0)
    code = sizes.fit(np.array([zdr_db]))
    lam = float(sizes.lam[code[0]])
    ref = reference_moments(lam, eps)
    assert float(sizes.zdr_db[code[0]]) == pytest.approx(zdr_db, abs=0.01)
    assert float(sizes.zdr_db[code[0]]) == pytest.approx(ref["zdr_db"], abs=0.002)
    assert float(sizes.rho_hv(code)[0]) == pytest.approx(ref["rho_hv"], abs=2e-5)
    kdp = float(sizes.kdp_deg_per_km(code, np.array([0.0]))[0])
    assert kdp == pytest.approx(ref["kdp_per_z"], rel=2e-3)
    root = optimize.brentq(
        lambda x: reference_moments(x, eps)["zdr_db"] - zdr_db, 0.9, 50.0, xtol=1e-4
    )
    assert lam == pytest.approx(root, rel=0.01)


def test_drops_give_back_zdr_and_the_distributions_rho_hv():
    """A uniform cell of 40 dBZ and ZDR 1.5 dB at the monte_carlo level with drop_sizes gamma.

    The drops' time series (10 beams, 110 gates, 64 pulses) give back ZDR within 0.1 dB,
    rho_hv (per gate, pooled over beams and pulses) within 0.002 of the quadrature over the
    fitted distribution (not the truth's imposed 0.98), and a PHIDP slope of 2 KDP within 5 %
    of the quadrature's KDP at 40 dBZ. Z comes back exactly (the expected power).
    """
    beams = np.arange(10)
    truth = uniform_truth(n_gates=120, DBZH=40.0, ZDR=1.5, RHOHV=0.98, PHIDP=0.0)
    inputs = chain_inputs(truth, beams)
    chunk = Chunk(beams=beams, seed=3, block_name="weather")
    equal = WeatherChannel(name="w", method="monte_carlo").process(inputs, chunk)
    block = WeatherChannel(name="w", method="monte_carlo", drop_sizes="gamma")
    out = block.process(inputs, chunk)
    iq = out["iq"][:, 5:-5].astype(np.complex128)
    h, v = iq[..., 0], iq[..., 1]
    p_h = (np.abs(h) ** 2).mean(axis=(0, 2))
    p_v = (np.abs(v) ** 2).mean(axis=(0, 2))
    x = (np.conj(h) * v).mean(axis=(0, 2))
    assert 10 * np.log10(p_h.mean() / p_v.mean()) == pytest.approx(1.5, abs=0.1)
    sizes = dsd.DropSizes.build(FREQUENCY, 10.0)
    ref = reference_moments(
        float(sizes.lam[sizes.fit(np.array([1.5]))[0]]), dsd.water_permittivity(FREQUENCY, 10.0)
    )
    rho = np.mean(np.abs(x) / np.sqrt(p_h * p_v))
    assert rho == pytest.approx(ref["rho_hv"], abs=0.002)
    assert abs(rho - 0.98) > 0.01
    rng = truth["range"].values[5:-5]
    slope = np.polyfit(rng / 1e3, np.unwrap(np.angle(x)), 1)[0]
    assert np.rad2deg(slope) == pytest.approx(2 * ref["kdp_per_z"] * 1e4, rel=0.05)
    # The expected power (the radar equation) is the truth's Z, as with equal drops.
    np.testing.assert_allclose(
        out["signal_power"][..., 0], equal["signal_power"][..., 0], rtol=1e-6
    )


def test_the_other_levels_ignore_drop_sizes():
    """drop_sizes only changes the monte_carlo level: covariance with gamma is bit-identical to
    covariance with equal drops (so a gamma graph runs through pasim tradeoff's ladder)."""
    beams = np.arange(3)
    inputs = chain_inputs(uniform_truth(n_gates=40, ZDR=1.5), beams)
    chunk = Chunk(beams=beams, seed=1, block_name="w")
    outs = [
        WeatherChannel(name="w", method="covariance", drop_sizes=d).process(inputs, chunk)
        for d in ("equal", "gamma")
    ]
    for key in ("iq", "signal_power", "echo_correlations"):
        np.testing.assert_array_equal(outs[0][key], outs[1][key])
