"""Tests of the channel electronics (``blocks/electronics.py``) on the arrays.

What each test compares against:

* quantisation: the rms error of an n-bit phase shifter over uniformly spread phases,
  2 pi / (2^n sqrt 12), and of an attenuator, LSB / sqrt 12 in dB (uniform rounding error);
* reproducibility: the same seed gives the same array, whatever impairments are switched on;
  the failed fraction follows the binomial law;
* the paper's section 2.2.2 impairments on the 10 m CPPAR (0.5 dB / 6 deg, 5 % failures,
  5-bit phase shifters), averaged over 20 seeds: the peak sidelobe rises at least 3 dB and the
  gain drops (paper conclusion 3), and the average sidelobe level agrees within 2 dB with the
  textbook random-error level (sigma_a^2 + sigma_phi^2 + P_f + sigma_q^2) / (N eta) of
  Mailloux (Phased Array Antenna Handbook), computed here from the parameters;
* quantisation alone raises the sidelobes; on a planar array steered off broadside the 5-bit
  errors of a linear phase progression are periodic and make quantisation lobes, which
  randomised quantisation spreads into a floor near sigma_q^2 / (N eta);
* subarray-level steering: grating lobes at the subarray spacing, sin(theta_g) = sin(theta_0)
  - lambda / D_sub (array theory).
"""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.antennas.cylindrical import CylindricalArray
from pasim_blocks.antennas.electronics import ChannelModel, array_rng
from pasim_blocks.antennas.measures import peak_sidelobe_db
from pasim_blocks.antennas.planar import PlanarPatchArray
from pasim_blocks.antennas.tapers import taper_efficiency

C = 299_792_458.0
LAMBDA = C / 2.8e9
IMPAIRED = {
    "amplitude_error_db": 0.5,
    "phase_error_deg": 6.0,
    "failure_probability": 0.05,
    "phase_bits": 5,
}


# ---- the channel model ------------------------------------------------------------------------


@pytest.mark.parametrize("bits", [3, 5, 6])
def test_phase_quantisation_rms_error(bits: int) -> None:
    """Phases spread uniformly over the circle: rms error 2 pi / (2^n sqrt 12), within 2 %,
    and no error larger than half a step."""
    model = ChannelModel(phase_bits=bits)
    phase = np.random.default_rng(1).uniform(-20, 20, 200_000)
    error = model.quantise_phase(phase, None) - phase
    step = 2 * np.pi / 2**bits
    assert np.sqrt(np.mean(error**2)) == pytest.approx(step / np.sqrt(12), rel=0.02)
    assert np.max(np.abs(error)) <= step / 2 + 1e-12


def test_randomised_quantisation_keeps_the_phase_and_error_bound() -> None:
    """With insertion phases the realised phase still lies within half a step of the command
    (the offsets are known and added back)."""
    model = ChannelModel(phase_bits=4, randomize_quantization=True)
    rng = np.random.default_rng(2)
    phase = rng.uniform(-10, 10, 10_000)
    offset = rng.uniform(0, 2 * np.pi, 10_000)
    error = model.quantise_phase(phase, offset) - phase
    assert np.max(np.abs(error)) <= np.pi / 16 + 1e-12


def test_attenuator_quantisation() -> None:
    """6 bits of 0.5 dB: every realised amplitude is a whole number of steps below the peak,
    the error is within half a step (rms LSB / sqrt 12 over a Taylor taper's spread of
    levels), and levels below the range are clipped to the deepest step."""
    model = ChannelModel(attenuator_bits=6, attenuator_lsb_db=0.5)
    taper = np.linspace(1.0, 0.05, 5000)
    realised = model.quantise_amplitude(taper)
    steps = -20 * np.log10(realised) / 0.5
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    error_db = 20 * np.log10(realised / taper)
    assert np.max(np.abs(error_db)) <= 0.25 + 1e-9
    assert np.sqrt(np.mean(error_db**2)) == pytest.approx(0.5 / np.sqrt(12), rel=0.05)
    coarse = ChannelModel(attenuator_bits=2, attenuator_lsb_db=1.0)
    assert coarse.quantise_amplitude(np.array([1.0, 0.01]))[1] == pytest.approx(10 ** (-3 / 20))


def test_same_seed_same_array_whatever_is_switched_on() -> None:
    """The draws come in a fixed order: switching failures or quantisation on does not change
    the amplitude and phase errors of the same seed; another seed gives another array. The
    failed fraction of 100 000 modules is 5 % within 4 binomial standard deviations."""
    a = ChannelModel(amplitude_error_db=0.5, phase_error_deg=6.0)
    b = ChannelModel(amplitude_error_db=0.5, phase_error_deg=6.0, failure_probability=0.05)
    da = a.draw((100_000,), array_rng(3, "antenna", None))
    db = b.draw((100_000,), array_rng(3, "antenna", None))
    alive = db.gain[0] != 0
    np.testing.assert_array_equal(da.gain[:, alive], db.gain[:, alive])
    assert np.all(db.gain[1][~alive] == 0)  # a failed module is dead on both ports
    p = 1 - alive.mean()
    assert abs(p - 0.05) < 4 * np.sqrt(0.05 * 0.95 / 100_000)
    other = a.draw((100_000,), array_rng(4, "antenna", None))
    assert not np.allclose(other.gain, da.gain)
    # amplitude errors are 0.5 dB rms, phase errors 6 deg rms
    assert np.std(20 * np.log10(np.abs(da.gain))) == pytest.approx(0.5, rel=0.02)
    assert np.degrees(np.std(np.angle(da.gain))) == pytest.approx(6.0, rel=0.02)
    # a fixed errors_seed ignores the run seed; the block name keys the run-seed draw
    fixed = [array_rng(s, "antenna", 11).standard_normal() for s in (0, 1)]
    assert fixed[0] == fixed[1]
    assert array_rng(0, "a", None).standard_normal() != array_rng(0, "b", None).standard_normal()


def test_array_block_draws_from_the_run_seed() -> None:
    """The planar block with errors: the same run seed gives the same pattern, another seed
    another one; with errors_seed set the run seed no longer matters."""
    block = PlanarPatchArray(name="antenna", n_x=16, n_y=16, **IMPAIRED)
    az, el = np.linspace(280, 290, 50), np.zeros(50)
    f0 = block.fields_at(285.0, 0.0, az, el, seed=0).h_co
    np.testing.assert_array_equal(f0, block.fields_at(285.0, 0.0, az, el, seed=0).h_co)
    assert not np.allclose(f0, block.fields_at(285.0, 0.0, az, el, seed=1).h_co)
    fixed = PlanarPatchArray(name="antenna", n_x=16, n_y=16, errors_seed=5, **IMPAIRED)
    np.testing.assert_array_equal(
        fixed.fields_at(285.0, 0.0, az, el, seed=0).h_co,
        fixed.fields_at(285.0, 0.0, az, el, seed=9).h_co,
    )


# ---- the paper's impairments on the 10 m CPPAR ---------------------------------------------------


@pytest.fixture(scope="module")
def cppar_cut():
    """Azimuth cut (+-45 deg, 0.02 deg) of the 10 m CPPAR at 0 deg elevation: the column
    matrix once, then the weights of each seed (fields_at = matrix @ weights)."""
    ideal = CylindricalArray(name="antenna", elements_per_column=8)
    impaired = CylindricalArray(name="antenna", elements_per_column=8, **IMPAIRED)
    quantised = CylindricalArray(name="antenna", elements_per_column=8, phase_bits=5)
    az0, _ = ideal.broadside()
    d = np.arange(-45.0, 45.0001, 0.02)
    matrix = ideal.column_matrix(az0, 0.0, az0 + d, np.zeros_like(d))[0]  # H co-polar

    def cut(block, seed):
        first, offset = block.sector(az0)
        w = block.column_weights(first, offset * block.column_step_deg, 0.0, seed)[0]
        return np.abs(matrix @ w) ** 2

    # The shortcut is the block's own evaluation.
    np.testing.assert_allclose(
        cut(impaired, 3),
        np.abs(impaired.fields_at(az0, 0.0, az0 + d, np.zeros_like(d), seed=3).h_co) ** 2,
        rtol=1e-9,
        atol=1e-15,
    )
    return {
        "d": d,
        "ideal": cut(ideal, 0),
        "impaired": np.array([cut(impaired, s) for s in range(20)]),
        "quantised": cut(quantised, 0),
        "eta": taper_efficiency(ideal.amplitude),
        "n": ideal.p["excited_columns"],
    }


def test_impairments_raise_peak_sidelobe_and_lower_gain(cppar_cut) -> None:
    """Averaged over 20 seeds the peak sidelobe rises at least 3 dB above the ideal array's
    (measured -30.5 -> -26.0 dB) and the gain falls (measured 0.45 dB)."""
    d = cppar_cut["d"]
    ideal = peak_sidelobe_db(d, cppar_cut["ideal"])
    impaired = np.mean([peak_sidelobe_db(d, p) for p in cppar_cut["impaired"]])
    assert impaired > ideal + 3.0
    gain_drop_db = 10 * np.log10(
        cppar_cut["impaired"].max(axis=1).mean() / cppar_cut["ideal"].max()
    )
    assert gain_drop_db < -0.2


def test_average_sidelobe_level_is_the_random_error_formula(cppar_cut) -> None:
    """Mean over the 20 seeds of the power 5-20 deg from the beam (where the ideal pattern is
    more than 10 dB below it), relative to the ideal peak, against
    (sigma_a^2 + sigma_phi^2 + P_f + sigma_q^2) / (N eta): sigma_a = 0.5 dB as a relative
    amplitude (ln 10 / 20 * 0.5), sigma_phi = 6 deg in rad, P_f = 0.05, sigma_q = 2 pi /
    (32 sqrt 12), N = 156 columns, eta the taper efficiency. Within 2 dB (measured -33.4 dB
    against -33.0 dB)."""
    d = cppar_cut["d"]
    sigma2 = (
        (np.log(10) / 20 * 0.5) ** 2
        + np.deg2rad(6.0) ** 2
        + 0.05
        + (2 * np.pi / (2**5 * np.sqrt(12))) ** 2
    )
    formula_db = 10 * np.log10(sigma2 / (cppar_cut["n"] * cppar_cut["eta"]))
    region = (np.abs(d) >= 5) & (np.abs(d) <= 20)
    peak = cppar_cut["ideal"].max()
    ideal_db = 10 * np.log10(cppar_cut["ideal"][region].mean() / peak)
    assert ideal_db < formula_db - 10  # the region is the errors' own
    measured_db = 10 * np.log10(cppar_cut["impaired"][:, region].mean() / peak)
    assert measured_db == pytest.approx(formula_db, abs=2.0)


def test_quantisation_alone_raises_the_sidelobes(cppar_cut) -> None:
    """5-bit phase shifters only: the cylinder's steering phases are not a linear progression,
    so the errors act as a pseudo-random floor near sigma_q^2 / (N eta) (-46 dB): the mean
    sidelobe level 5-45 deg from the beam rises by more than 2 dB (measured ~3 dB), the peak
    sidelobe does not fall."""
    d = cppar_cut["d"]
    region = np.abs(d) >= 5
    ideal = cppar_cut["ideal"][region].mean()
    quantised = cppar_cut["quantised"][region].mean()
    assert 10 * np.log10(quantised / ideal) > 2.0
    assert peak_sidelobe_db(d, cppar_cut["quantised"]) >= peak_sidelobe_db(d, cppar_cut["ideal"])


# ---- planar: quantisation lobes, randomisation, subarrays ---------------------------------------


def planar_cut(steer_deg: float, seed: int = 0, **params) -> tuple[np.ndarray, np.ndarray]:
    """H co-polar power on the horizon of an 80 x 8 planar array facing north, steered in
    azimuth, against the azimuth offset from the beam (where the face can see)."""
    block = PlanarPatchArray(name="antenna", face_azimuth_deg=0.0, n_y=8, **params)
    d = np.arange(-85.0, 85.0, 0.02)
    keep = np.abs(steer_deg + d) < 89.0
    az = np.mod(steer_deg + d[keep], 360.0)
    f = block.fields_at(steer_deg, 0.0, az, np.zeros(keep.sum()), seed=seed)
    return d[keep], np.abs(f.h_co) ** 2


def test_quantisation_lobes_and_randomisation() -> None:
    """80 x 8 elements steered 20 deg in azimuth with 5-bit phase shifters: the periodic phase
    errors make a quantisation lobe (measured -31.5 dB, 43 deg from the beam) far above the
    ideal sidelobes beyond 15 deg (-37.3 dB); randomised quantisation removes it. What it
    leaves is a random floor: averaged over 4 seeds, the excess power beyond 15 deg is
    sigma_q^2 / (N eta) |E(theta)|^2 / |E(20 deg)|^2 within 2 dB (N = 640, eta the two
    tapers' efficiency, E the patch's H co-polar field; measured 0.5 dB below)."""
    from pasim_blocks.antennas.geometry import patch_element_field
    from pasim_blocks.antennas.tapers import taylor_taper

    d, ideal = planar_cut(20.0)
    _, lobes = planar_cut(20.0, phase_bits=5)
    far = np.abs(d) > 15
    peak = ideal.max()
    ideal_db = 10 * np.log10(ideal[far].max() / peak)
    assert 10 * np.log10(lobes[far].max() / peak) > ideal_db + 4.0
    excess = []
    for seed in range(4):
        _, spread = planar_cut(20.0, seed, phase_bits=5, randomize_quantization=True)
        assert 10 * np.log10(spread[far].max() / peak) < ideal_db + 1.5
        excess.append(np.mean(spread[far] - ideal[far]) / peak)
    element = patch_element_field(20.0 + d, 0.0, patch_m=0.0524, frequency_hz=2.8e9).h_co ** 2
    eta = taper_efficiency(taylor_taper(80, -30, 5)) * taper_efficiency(taylor_taper(8, -30, 5))
    sigma_q2 = (2 * np.pi / 2**5) ** 2 / 12
    predicted = sigma_q2 / (640 * eta) * element[far].mean() / element[np.argmin(np.abs(d))]
    assert 10 * np.log10(np.mean(excess)) == pytest.approx(10 * np.log10(predicted), abs=2.0)


def test_subarray_steering_makes_grating_lobes() -> None:
    """One phase shifter per 8-element subarray (3.9 lambda apart) steered 20 deg: grating
    lobes at sin(theta) = sin(20 deg) - k lambda / (8 d); the first (k = 1) stands far above
    the element-steered array's sidelobes there. At broadside both are the same array."""
    d, element = planar_cut(20.0, subarray_x=8, subarray_y=8)
    _, sub = planar_cut(20.0, subarray_x=8, subarray_y=8, steering="subarray")
    grating = np.degrees(np.arcsin(np.sin(np.radians(20)) - LAMBDA / (8 * 0.0524)))
    near = np.abs(d - (grating - 20.0)) < 1.0
    peak = element.max()
    assert 10 * np.log10(sub[near].max() / peak) > -15
    assert 10 * np.log10(element[near].max() / peak) < -35
    _, e0 = planar_cut(0.0, subarray_x=8, subarray_y=8)
    _, s0 = planar_cut(0.0, subarray_x=8, subarray_y=8, steering="subarray")
    np.testing.assert_allclose(s0, e0, rtol=1e-9, atol=1e-15)


def test_general_path_matches_the_separable_path() -> None:
    """16-bit phase shifters (errors below 1e-4 rad) take the non-separable weight path; the
    pattern agrees with the ideal separable one within 1e-4 of the peak."""
    az, el = np.meshgrid(np.linspace(250, 300, 60), np.linspace(-5, 15, 40))
    ideal = PlanarPatchArray(name="a", n_x=24, n_y=20)
    fine = PlanarPatchArray(name="a", n_x=24, n_y=20, phase_bits=16)
    a = ideal.fields_at(270.0, 5.0, az, el)
    b = fine.fields_at(270.0, 5.0, az, el)
    for x, y in zip(a, b, strict=True):
        assert np.max(np.abs(np.asarray(x) - np.asarray(y))) < 1e-4


def test_subarray_parameters_must_divide() -> None:
    assert PlanarPatchArray.check_config({"n_x": 80, "subarray_x": 7}, set())
    assert not PlanarPatchArray.check_config({"n_x": 80, "subarray_x": 8}, set())
