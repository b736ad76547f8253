"""Tests of the antenna pattern models in ``pasim_blocks.antennas.aperture``.

Every test names what it is compared against: closed-form aperture theory (Airy pattern,
tapered circular apertures), the paper's Table 4 generic radar, uniform and Taylor linear
array theory, the cos law of scan broadening and scan loss, and independent numerical
evaluations (quadrature, direct sums, vector algebra, integration over the hemisphere).
Run with ``pytest -s`` to see the measured numbers.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest
from pasim_blocks.antennas.aperture import PencilBeam, pencil_beam_power
from pasim_blocks.antennas.array_factor import (
    array_factor,
    planar_array_directivity_db,
    planar_array_power,
)
from pasim_blocks.antennas.geometry import patch_element_field
from pasim_blocks.antennas.measures import first_sidelobe_db, half_power_beamwidth_deg
from pasim_blocks.antennas.tapers import (
    SeparableWeights,
    element_positions,
    planar_array_weights,
    taper_efficiency,
    taylor_taper,
)
from pasim_blocks.signals import SPEED_OF_LIGHT
from scipy import optimize, special

FREQUENCY_HZ = 2.8e9
WAVELENGTH_M = SPEED_OF_LIGHT / FREQUENCY_HZ
SPACING_M = 0.0524
N_ELEMENTS = 80
TAYLOR_SLL_DB = -30.0
# nbar = 5 satisfies Taylor's condition nbar >= 2 A^2 + 1/2 (= 3.98 for 30 dB), so the taper
# is monotone and the near-in sidelobes sit at the design level.
TAYLOR_NBAR = 5
ARRAY = {
    "n_x": N_ELEMENTS,
    "n_y": N_ELEMENTS,
    "dx_m": SPACING_M,
    "dy_m": SPACING_M,
    "frequency_hz": FREQUENCY_HZ,
    "patch_m": 0.0524,
    "taylor_sll_db": TAYLOR_SLL_DB,
    "taylor_nbar": TAYLOR_NBAR,
}


def azimuth_cut(centre_deg: float, half_width_deg: float = 6.0, step_deg: float = 0.001):
    """H and V power on an elevation-0 azimuth cut of the array steered to (centre, 0)."""
    az = np.arange(centre_deg - half_width_deg, centre_deg + half_width_deg, step_deg)
    p_h, p_v = planar_array_power(az, 0.0, steer_az_deg=centre_deg, steer_el_deg=0.0, **ARRAY)
    return az, p_h, p_v


def hemisphere_directivity_db(steer_az_deg: float, step: float = 0.004) -> tuple[float, float]:
    """Directivity of the H and V patterns by midpoint integration over the face's hemisphere.

    Integrates in face direction cosines, where dOmega = du dv / w, so the pencil beam is
    sampled equally finely wherever it is steered.
    """
    grid = np.arange(-1.0 + step / 2, 1.0, step)
    u, v = np.meshgrid(grid, grid, indexing="ij")
    inside = u**2 + v**2 < 1.0
    u, v = u[inside], v[inside]
    w = np.sqrt(1.0 - u**2 - v**2)
    el = np.degrees(np.arcsin(v))
    az = np.degrees(np.arctan2(u, w))
    p_h, p_v = planar_array_power(az, el, steer_az_deg=steer_az_deg, steer_el_deg=0.0, **ARRAY)
    peak_h, peak_v = planar_array_power(
        steer_az_deg, 0.0, steer_az_deg=steer_az_deg, steer_el_deg=0.0, **ARRAY
    )
    d_h = 4 * np.pi * peak_h / (np.sum(p_h / w) * step**2)
    d_v = 4 * np.pi * peak_v / (np.sum(p_v / w) * step**2)
    return float(10 * np.log10(d_h)), float(10 * np.log10(d_v))


# ------------------------------------------------------------------------------------------
# Pencil beam (circular aperture)
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("taper_exponent", [0.0, 1.0, 2.25, 3.7])
def test_aperture_pattern_matches_quadrature_of_its_definition(taper_exponent):
    """Against Gauss-Legendre quadrature of int_0^1 (1-rho^2)^p J0(u rho) rho drho."""
    beam = PencilBeam.from_taper(taper_exponent, 20.0)
    theta = np.linspace(0.0, 50.0, 301)
    u = np.pi * beam.diameter_wavelengths * np.sin(np.radians(theta))
    nodes, weights = np.polynomial.legendre.leggauss(400)
    rho = 0.5 * (nodes + 1.0)
    g = (1.0 - rho**2) ** taper_exponent * rho * 0.5 * weights
    expected = special.j0(np.outer(u, rho)) @ g / g.sum()
    np.testing.assert_allclose(beam.amplitude(theta), expected, rtol=0, atol=1e-8)


def test_uniform_aperture_is_the_airy_pattern():
    """Against the Airy pattern (2 J1(u)/u)^2: first sidelobe -17.57 dB, HPBW 1.029 lambda/D."""
    diameter = 50.0
    beam = PencilBeam.from_taper(0.0, diameter)
    theta = np.arange(-5.0, 5.0, 0.0005)
    power = beam.power(theta)
    u = np.pi * diameter * np.sin(np.radians(theta))
    with np.errstate(invalid="ignore", divide="ignore"):
        airy = np.where(u == 0, 1.0, (2 * special.j1(u) / u) ** 2)
    np.testing.assert_allclose(power, airy, rtol=0, atol=1e-9)

    hpbw_rad = np.radians(half_power_beamwidth_deg(theta, power))
    sll = first_sidelobe_db(theta, power)
    print(
        f"\nuniform aperture D=50 lambda: HPBW = {hpbw_rad * diameter:.5f} lambda/D rad, "
        f"first sidelobe = {sll:.3f} dB"
    )
    assert hpbw_rad * diameter == pytest.approx(1.029, abs=1e-3)
    assert sll == pytest.approx(-17.57, abs=0.01)


@pytest.mark.parametrize(("taper_exponent", "expected_db"), [(1.0, -24.64), (2.0, -30.61)])
def test_tapered_aperture_sidelobes(taper_exponent, expected_db):
    """Against the textbook sidelobes of (1-rho^2)^p tapers: -24.6 dB (p=1), -30.6 dB (p=2)."""
    beam = PencilBeam.from_taper(taper_exponent, 50.0)
    theta = np.arange(-6.0, 6.0, 0.0005)
    measured = first_sidelobe_db(theta, beam.power(theta))
    print(f"\np={taper_exponent:g}: first sidelobe {measured:.3f} dB")
    assert measured == pytest.approx(expected_db, abs=0.05)
    assert beam.first_sidelobe_db == pytest.approx(measured, abs=0.01)


def test_designed_generic_beam_meets_table_4():
    """Against paper Table 4: 1.0 deg beamwidth, -32 dB first sidelobe (45.5 dB gain)."""
    beam = PencilBeam.design(1.0, -32.0)
    theta = np.arange(-5.0, 5.0, 0.0005)
    power = beam.power(theta)
    hpbw = half_power_beamwidth_deg(theta, power)
    sll = first_sidelobe_db(theta, power)
    print(
        f"\ngeneric beam: p = {beam.taper_exponent:.4f}, D = {beam.diameter_wavelengths:.3f} "
        f"lambda ({beam.diameter_wavelengths * WAVELENGTH_M:.3f} m at 2.8 GHz), "
        f"HPBW = {hpbw:.5f} deg, first sidelobe = {sll:.3f} dB, "
        f"directivity = {beam.directivity_db:.2f} dBi (taper efficiency "
        f"{beam.taper_efficiency:.3f})"
    )
    assert hpbw == pytest.approx(1.0, abs=0.01)
    assert sll == pytest.approx(-32.0, abs=0.1)
    # The paper's 45.5 dB is a gain (losses included); a lossless aperture must not be far off.
    assert beam.directivity_db == pytest.approx(45.5, abs=1.0)


@pytest.mark.parametrize("level_db", [-17.5, -15.0, -150.0])
def test_design_rejects_unreachable_sidelobe(level_db):
    """Above the uniform-illumination -17.57 dB (or below p=20) no taper of the family fits."""
    with pytest.raises(ValueError, match="not reachable"):
        PencilBeam.design(1.0, level_db)


def test_pencil_power_behind_the_aperture_is_the_90_degree_value():
    """Documented behaviour: beyond 90 deg off axis the pattern keeps its 90 deg value."""
    beam = PencilBeam.design(1.0, -32.0)
    far = beam.power(np.array([[90.0, 120.0], [-150.0, 180.0]]))
    assert far.shape == (2, 2)
    np.testing.assert_array_equal(far, beam.power(90.0))
    assert 0.0 <= float(beam.power(90.0)) < 1e-12


def test_pencil_beam_grid_uses_great_circle_angle():
    """Against sqrt(d_az^2 cos^2 el + d_el^2) for small offsets and vector algebra at 60 deg."""
    beam = PencilBeam.design(1.0, -32.0)
    d_az = np.linspace(-10, 10, 400)[:, None]
    d_el = np.linspace(-5, 5, 200)[None, :]
    grid = pencil_beam_power(d_az, d_el, beam)
    assert grid.shape == (400, 200)
    assert float(pencil_beam_power(0.0, 0.0, beam)) == pytest.approx(1.0, abs=1e-12)

    small_az = np.linspace(-2, 2, 81)[:, None]
    small_el = np.linspace(-2, 2, 81)[None, :]
    cos_el0 = np.cos(np.radians(0.5))
    approx = beam.power(np.hypot(small_az * cos_el0, small_el))
    np.testing.assert_allclose(pencil_beam_power(small_az, small_el, beam), approx, atol=2e-3)

    # At el0 = 60 deg a 1.6 deg azimuth step is only ~0.8 deg off axis.
    def unit(az, el):
        az, el = np.radians(az), np.radians(el)
        return np.array([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)])

    off_axis = np.degrees(np.arccos(unit(1.6, 60.3) @ unit(0.0, 60.0)))
    value = pencil_beam_power(1.6, 0.3, beam, el0_deg=60.0)
    assert float(value) == pytest.approx(float(beam.power(off_axis)), rel=1e-6)
    along_azimuth = float(pencil_beam_power(1.6, 0.0, beam, el0_deg=60.0))
    assert along_azimuth == pytest.approx(float(beam.power(1.6 * np.cos(np.radians(60)))), rel=1e-3)
    assert along_azimuth > 100 * float(beam.power(1.6))


# ------------------------------------------------------------------------------------------
# Planar array: element, array factor, beam shape
# ------------------------------------------------------------------------------------------


def test_patch_element_matches_vector_cavity_model():
    """Against the cavity model built with explicit 3-D vectors (np.cross) on a tilted face."""
    rng = np.random.default_rng(1)
    az = rng.uniform(-180, 180, 2000)
    el = rng.uniform(-89, 89, 2000)
    face_az, tilt, patch = 30.0, 15.0, 0.0524
    field = patch_element_field(
        az,
        el,
        patch_m=patch,
        frequency_hz=FREQUENCY_HZ,
        face_azimuth_deg=face_az,
        face_tilt_deg=tilt,
    )

    def unit(a, e):
        a, e = np.radians(a), np.radians(e)
        return np.stack([np.cos(e) * np.sin(a), np.cos(e) * np.cos(a), np.sin(e)], axis=-1)

    r = unit(az, el)
    a, e = np.radians(az), np.radians(el)
    h_hat = np.stack([np.cos(a), -np.sin(a), 0 * a], axis=-1)
    v_hat = np.stack([-np.sin(e) * np.sin(a), -np.sin(e) * np.cos(a), np.cos(e)], axis=-1)
    normal = unit(face_az, tilt)
    x_face = np.array([np.cos(np.radians(face_az)), -np.sin(np.radians(face_az)), 0.0])
    y_face = np.cross(x_face, normal)
    assert y_face[2] > 0  # "up the face"
    u, v, w = r @ x_face, r @ y_face, r @ normal
    size = patch * FREQUENCY_HZ / SPEED_OF_LIGHT
    s_h = np.cos(np.pi * size * u) * np.sinc(size * v) * (w > 0)
    s_v = np.cos(np.pi * size * v) * np.sinc(size * u) * (w > 0)
    e_h = s_h[:, None] * np.cross(r, y_face)
    e_v = s_v[:, None] * np.cross(x_face, r)
    np.testing.assert_allclose(field.h_co, np.sum(e_h * h_hat, -1), atol=1e-12)
    np.testing.assert_allclose(field.h_cross, np.sum(e_h * v_hat, -1), atol=1e-12)
    np.testing.assert_allclose(field.v_co, np.sum(e_v * v_hat, -1), atol=1e-12)
    np.testing.assert_allclose(field.v_cross, np.sum(e_v * h_hat, -1), atol=1e-12)
    # Total H-port field is the brief's cos(kLu/2) sinc(kLv/2) sqrt(1 - v^2).
    np.testing.assert_allclose(
        np.hypot(field.h_co, field.h_cross), np.abs(s_h) * np.sqrt(1 - v**2), atol=1e-12
    )
    assert np.all(field.h_co[w <= 0] == 0) and np.all(field.v_co[w <= 0] == 0)
    broadside = patch_element_field(
        face_az,
        tilt,
        patch_m=patch,
        frequency_hz=FREQUENCY_HZ,
        face_azimuth_deg=face_az,
        face_tilt_deg=tilt,
    )
    assert float(broadside.h_co) == pytest.approx(1.0) and float(broadside.v_co) == pytest.approx(1)


@pytest.mark.parametrize("n", [80, 81, 7])
def test_array_factor_fast_and_general_paths_match_direct_sum(n):
    """Against the direct double sum of W[m, n] exp(j k (x_m u + y_n v))."""
    weights = planar_array_weights(
        steer_az_deg=20.0,
        steer_el_deg=5.0,
        n_x=n,
        n_y=n,
        dx_m=SPACING_M,
        dy_m=SPACING_M,
        frequency_hz=FREQUENCY_HZ,
        taylor_sll_db=TAYLOR_SLL_DB,
        taylor_nbar=TAYLOR_NBAR,
        face_tilt_deg=10.0,
    )
    rng = np.random.default_rng(n)
    u = rng.uniform(-2.5, 2.5, 1500)  # beyond +-1 too: the table is periodic in psi
    v = rng.uniform(-2.5, 2.5, 1500)
    k = 2 * np.pi / WAVELENGTH_M
    x = element_positions(n, SPACING_M)
    full = weights.full()
    direct = np.einsum(
        "pm,mn,pn->p", np.exp(1j * k * np.outer(u, x)), full, np.exp(1j * k * np.outer(v, x))
    )
    scale = np.abs(full).sum()
    common = {"dx_m": SPACING_M, "dy_m": SPACING_M, "frequency_hz": FREQUENCY_HZ}
    fast = array_factor(u, v, weights, **common)
    general = array_factor(u, v, full, **common)
    assert np.max(np.abs(fast - direct)) / scale < 1e-8
    assert np.max(np.abs(general - direct)) / scale < 1e-12


def test_broadside_beamwidth_against_uniform_and_taylor_line_theory():
    """Against the uniform-line half-power root and Taylor's beam-broadening formula."""
    az, p_h, p_v = azimuth_cut(0.0, step_deg=0.002)
    n, d, k = N_ELEMENTS, SPACING_M, 2 * np.pi / WAVELENGTH_M

    # Uniform line, independently: |sin(N psi/2) / (N sin(psi/2))|^2 = 1/2.
    psi_half = optimize.brentq(
        lambda p: (np.sin(n * p / 2) / (n * np.sin(p / 2))) ** 2 - 0.5, 1e-6, 2 * np.pi / n
    )
    uniform_theory = np.degrees(2 * np.arcsin(psi_half / (k * d)))
    assert uniform_theory == pytest.approx(np.degrees(0.886 * WAVELENGTH_M / (n * d)), rel=1e-3)
    ones = SeparableWeights(np.ones(n, complex), np.ones(n, complex))
    uniform_af = array_factor(
        np.sin(np.radians(az)), 0.0, ones, dx_m=d, dy_m=d, frequency_hz=FREQUENCY_HZ
    )
    uniform_measured = half_power_beamwidth_deg(az, np.abs(uniform_af) ** 2)

    # Taylor: sigma * (2/pi) sqrt(acosh(R)^2 - acosh(R/sqrt2)^2) lambda / L.
    ratio = 10 ** (-TAYLOR_SLL_DB / 20)
    a = np.arccosh(ratio) / np.pi
    sigma = TAYLOR_NBAR / np.sqrt(a**2 + (TAYLOR_NBAR - 0.5) ** 2)
    taylor_theory = np.degrees(
        sigma
        * 2
        / np.pi
        * np.sqrt(np.arccosh(ratio) ** 2 - np.arccosh(ratio / np.sqrt(2)) ** 2)
        * WAVELENGTH_M
        / (n * d)
    )
    hpbw_h = half_power_beamwidth_deg(az, p_h)
    hpbw_v = half_power_beamwidth_deg(az, p_v)
    print(
        f"\n80x80 broadside azimuth HPBW: uniform theory {uniform_theory:.4f} deg, uniform "
        f"measured {uniform_measured:.4f} deg; Taylor theory {taylor_theory:.4f} deg, "
        f"measured H {hpbw_h:.4f} / V {hpbw_v:.4f} deg (broadening {hpbw_h / uniform_measured:.3f})"
    )
    assert uniform_measured == pytest.approx(uniform_theory, rel=1e-3)
    assert hpbw_h == pytest.approx(taylor_theory, rel=0.02)
    assert hpbw_h > 1.15 * uniform_measured


def test_broadside_first_sidelobe_meets_taylor_design():
    """Against the Taylor design level: first sidelobes at about -30 dB in both principal cuts."""
    az, p_h, p_v = azimuth_cut(0.0, step_deg=0.002)
    el = np.arange(-6.0, 6.0, 0.002)
    e_h, e_v = planar_array_power(0.0, el, steer_az_deg=0.0, steer_el_deg=0.0, **ARRAY)
    levels = {
        "az H": first_sidelobe_db(az, p_h),
        "az V": first_sidelobe_db(az, p_v),
        "el H": first_sidelobe_db(el, e_h),
        "el V": first_sidelobe_db(el, e_v),
    }
    print("\nbroadside first sidelobes: " + ", ".join(f"{k} {v:.2f} dB" for k, v in levels.items()))
    for level in levels.values():
        assert -31.0 < level < -30.0


def test_scan_to_45_degrees_follows_cos_law():
    """Against the cos law: HPBW grows as 1/cos(45), directivity falls as cos(45)."""
    _, p0_h, _ = azimuth_cut(0.0)
    az, p45_h, p45_v = azimuth_cut(45.0)
    az0 = np.arange(-6.0, 6.0, 0.001)
    broadening = half_power_beamwidth_deg(az, p45_h) / half_power_beamwidth_deg(az0, p0_h)

    d0_h, d0_v = hemisphere_directivity_db(0.0)
    d45_h, d45_v = hemisphere_directivity_db(45.0)
    cos_law_db = 10 * np.log10(np.cos(np.radians(45.0)))

    # The normalised pattern's peak is the isolated element's power pattern at the scan angle.
    size = ARRAY["patch_m"] / WAVELENGTH_M
    u0 = np.sin(np.radians(45.0))
    element_h = np.cos(np.pi * size * u0) ** 2
    element_v = (np.sinc(size * u0) * np.cos(np.radians(45.0))) ** 2
    at_steer_h, at_steer_v = planar_array_power(
        45.0, 0.0, steer_az_deg=45.0, steer_el_deg=0.0, **ARRAY
    )
    inverse_cos = 1 / np.cos(np.radians(45.0))
    print(
        f"\nscan to 45 deg: azimuth broadening {broadening:.4f} (1/cos = {inverse_cos:.4f});"
        f" directivity H {d0_h:.3f} -> {d45_h:.3f} dBi, V {d0_v:.3f} -> {d45_v:.3f} dBi "
        f"(change {d45_h - d0_h:.3f} / {d45_v - d0_v:.3f} dB, cos law {cos_law_db:.3f} dB); "
        f"normalised pattern peak H {10 * np.log10(p45_h.max()):.2f} dB at "
        f"{az[np.argmax(p45_h)]:.3f} deg, V {10 * np.log10(p45_v.max()):.2f} dB at "
        f"{az[np.argmax(p45_v)]:.3f} deg (isolated-element scan loss)"
    )
    assert broadening == pytest.approx(1 / np.cos(np.radians(45.0)), rel=0.03)
    assert d45_h - d0_h == pytest.approx(cos_law_db, rel=0.03)
    assert d45_v - d0_v == pytest.approx(cos_law_db, rel=0.03)
    assert float(at_steer_h) == pytest.approx(element_h, rel=1e-9)
    assert float(at_steer_v) == pytest.approx(element_v, rel=1e-9)
    assert p45_h.max() < 1.0 and p45_v.max() < 1.0


def test_directivity_formula_against_hemisphere_integration():
    """Against 4 pi P_peak / (integral of the pattern over the hemisphere), within 0.3 dB."""
    formula = planar_array_directivity_db(
        n_x=N_ELEMENTS,
        n_y=N_ELEMENTS,
        dx_m=SPACING_M,
        dy_m=SPACING_M,
        frequency_hz=FREQUENCY_HZ,
        taylor_sll_db=TAYLOR_SLL_DB,
        taylor_nbar=TAYLOR_NBAR,
    )
    taper = taylor_taper(N_ELEMENTS, TAYLOR_SLL_DB, TAYLOR_NBAR)
    uniform = 10 * np.log10(4 * np.pi * (N_ELEMENTS * SPACING_M) ** 2 / WAVELENGTH_M**2)
    d_h, d_v = hemisphere_directivity_db(0.0)
    print(
        f"\n80x80 directivity: aperture {uniform:.3f} dBi, taper loss "
        f"{uniform - formula:.3f} dB, formula {formula:.3f} dBi, integrated H {d_h:.3f} / "
        f"V {d_v:.3f} dBi"
    )
    assert uniform - formula == pytest.approx(-20 * np.log10(taper_efficiency(taper)), abs=1e-9)
    assert d_h == pytest.approx(formula, abs=0.3)
    assert d_v == pytest.approx(formula, abs=0.3)


def test_zdr_bias_is_zero_at_broadside_and_grows_with_azimuth_scan():
    """Against the square-patch symmetry (P_H = P_V at broadside) and the element ratio."""
    size = ARRAY["patch_m"] / WAVELENGTH_M
    rows = []
    for steer in np.arange(0.0, 46.0, 5.0):
        az, p_h, p_v = azimuth_cut(float(steer), half_width_deg=1.5)
        i = int(np.argmax(p_h))
        bias_peak = 10 * np.log10((p_h[i] / p_v[i]) ** 2)
        h, v = planar_array_power(steer, 0.0, steer_az_deg=steer, steer_el_deg=0.0, **ARRAY)
        bias_steer = 10 * np.log10((float(h) / float(v)) ** 2)
        u0 = np.sin(np.radians(steer))
        element = (
            np.cos(np.pi * size * u0) ** 2 / (np.sinc(size * u0) * np.cos(np.radians(steer))) ** 2
        )
        assert bias_steer == pytest.approx(20 * np.log10(element), abs=1e-9)
        rows.append((steer, az[i], bias_peak, bias_steer))
    print("\nsteer az [deg] | H peak az [deg] | two-way ZDR bias at H peak / at steer [dB]")
    for steer, peak_az, bias_peak, bias_steer in rows:
        print(f"{steer:14.0f} | {peak_az:15.3f} | {bias_peak:8.3f} / {bias_steer:8.3f}")
    biases = np.array([row[3] for row in rows])
    assert abs(biases[0]) < 1e-9
    assert np.all(np.diff(biases) < 0)  # H falls off faster than V: bias ever more negative
    assert abs(rows[-1][2] - rows[-1][3]) < 0.05


def test_tilted_face_and_rear_hemisphere():
    """Against geometry: a tilted face's broadside gives peak 1, P_H = P_V; behind it, zero."""
    common = {**ARRAY, "face_azimuth_deg": 120.0, "face_tilt_deg": 10.0}
    p_h, p_v = planar_array_power(120.0, 10.0, steer_az_deg=120.0, steer_el_deg=10.0, **common)
    assert float(p_h) == pytest.approx(1.0, abs=1e-9)
    assert float(p_v) == pytest.approx(1.0, abs=1e-9)
    back_h, back_v = planar_array_power(
        [300.0, 250.0], [-10.0, 0.0], steer_az_deg=120.0, steer_el_deg=10.0, **common
    )
    assert np.all(back_h == 0) and np.all(back_v == 0)
    with pytest.raises(ValueError, match="not in front"):
        planar_array_power(0.0, 0.0, steer_az_deg=300.0, steer_el_deg=0.0, **common)


# ------------------------------------------------------------------------------------------
# Vectorisation (no wall-clock asserts)
# ------------------------------------------------------------------------------------------


def _python_calls(func) -> int:
    """Number of Python and C function calls made while running ``func`` a second time (the
    first fills caches, whose hits and misses depend on what earlier tests computed)."""
    func()
    count = 0

    def profiler(frame, event, arg):
        nonlocal count
        if event in ("call", "c_call"):
            count += 1

    sys.setprofile(profiler)
    try:
        func()
    finally:
        sys.setprofile(None)
    return count


def test_pattern_evaluation_has_no_python_loop_over_elements_or_directions():
    """The number of interpreted calls must not grow with the element count or the grid size."""

    def planar(n, n_az, n_el):
        az = np.linspace(-60, 60, n_az)[:, None]
        el = np.linspace(-5, 30, n_el)[None, :]
        config = {**ARRAY, "n_x": n, "n_y": n}
        return lambda: planar_array_power(az, el, steer_az_deg=10.0, steer_el_deg=3.0, **config)

    small = _python_calls(planar(8, 4, 2))
    assert _python_calls(planar(80, 400, 200)) == small
    assert _python_calls(planar(80, 4, 2)) == small
    assert _python_calls(planar(8, 400, 200)) == small

    beam = PencilBeam.design(1.0, -32.0)

    def pencil(n_az, n_el):
        return lambda: pencil_beam_power(
            np.linspace(-10, 10, n_az)[:, None], np.linspace(-5, 5, n_el)[None, :], beam
        )

    assert _python_calls(pencil(400, 200)) == _python_calls(pencil(4, 2))
