"""Tests of the transmit waveform and amplifier blocks (``blocks/waveform.py``, ``amplifier.py``).

What each test compares against:

* the rectangular pulse: its definition (``round(width x rate)`` samples of amplitude 1);
* the ideal amplifier: identity (the drive comes out unchanged);
* the Saleh amplifier: the paper's equations 3 and 4 (AM/AM ``A(r) = alpha_a r / (1 + beta_a
  r^2)``, AM/PM ``Phi(r) = alpha_phi r^2 / (1 + beta_phi r^2)``), written out again in this
  file, with the drive ``r = 10^(-backoff/20) / sqrt(beta_a)`` and the output normalised to
  ``A(r_sat) = alpha_a / (2 sqrt(beta_a))``; and the paper's section 2.2.2 parameter values.

Everything here is deterministic, so the tolerances are floating-point ones.
"""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.amplifier import IdealAmplifier, SalehAmplifier
from pasim_blocks.waveform import RectangularPulse, pulse_dataset

from pasim_graph import Chunk

# Paper section 2.2.2: the solid-state power amplifier's Saleh parameters.
PAPER_SALEH = {"alpha_a": 2.1587, "beta_a": 1.1517, "alpha_phi": 4.0033, "beta_phi": 9.1040}
NO_BEAMS = Chunk(beams=np.arange(0))


def am_am(r: np.ndarray, alpha_a: float, beta_a: float) -> np.ndarray:
    """Paper eq. 3, independent of the block's ``saleh`` helper."""
    return alpha_a * r / (1.0 + beta_a * r**2)


def am_pm(r: np.ndarray, alpha_phi: float, beta_phi: float) -> np.ndarray:
    """Paper eq. 4 (radians), independent of the block's ``saleh`` helper."""
    return alpha_phi * r**2 / (1.0 + beta_phi * r**2)


def amplify(envelope: np.ndarray, backoff_db: float, **params: float) -> np.ndarray:
    block = SalehAmplifier(name="hpa", input_backoff_db=backoff_db, **params)
    out = block.process({"pulse_in": pulse_dataset(envelope, 20e6)}, NO_BEAMS)["pulse"]
    return out["envelope"].values


@pytest.mark.parametrize(
    ("width_s", "rate_hz"), [(1.6e-6, 20e6), (1.0e-6, 5e6), (50e-6, 5e6), (1.6e-6, 1e6)]
)
def test_rectangular_pulse_samples_and_amplitude(width_s: float, rate_hz: float) -> None:
    """Sample count = width x rate (rounded), every sample amplitude 1, phase constant."""
    block = RectangularPulse(name="wf", width_s=width_s, sample_rate_hz=rate_hz)
    pulse = block.process({}, NO_BEAMS)["pulse"]
    env = pulse["envelope"].values
    assert env.size == round(width_s * rate_hz)
    np.testing.assert_allclose(np.abs(env), 1.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.angle(env), np.angle(env[0]), rtol=0, atol=1e-15)
    assert pulse.attrs["sample_rate_hz"] == rate_hz
    # Sample times are k / fs, so the pulse spans width_s.
    np.testing.assert_allclose(pulse["time"].values, np.arange(env.size) / rate_hz)
    # The sampled pulse lasts the nominal width to within half a sample (rounding).
    assert abs(env.size / rate_hz - width_s) <= 0.5 / rate_hz + 1e-15


def test_ideal_amplifier_is_identity() -> None:
    """A linear amplifier passes any envelope unchanged (amplitude and phase)."""
    rng = np.random.default_rng(7)
    env = rng.standard_normal(40) + 1j * rng.standard_normal(40)
    ds = pulse_dataset(env, 10e6, waveform="test")
    out = IdealAmplifier(name="hpa").process({"pulse_in": ds}, NO_BEAMS)["pulse"]
    np.testing.assert_array_equal(out["envelope"].values, env)
    assert out.attrs["sample_rate_hz"] == 10e6


def test_saleh_defaults_are_the_papers() -> None:
    """The default parameters are the paper's section 2.2.2 values."""
    block = SalehAmplifier(name="hpa")
    for key, value in PAPER_SALEH.items():
        assert block.p[key] == value


@pytest.mark.parametrize("backoff_db", [0.0, 1.0, 3.0, 6.0, 10.0, 20.0])
def test_saleh_am_am_and_am_pm_match_paper_equations(backoff_db: float) -> None:
    """Output amplitude and phase of a constant drive at several backoffs vs eq. 3 and 4.

    The drive peak sits ``backoff_db`` below the saturating input r_sat = 1/sqrt(beta_a); the
    amplitude is normalised to A(r_sat) = alpha_a / (2 sqrt(beta_a)), and the phase added by
    the amplifier is Phi(r) (the drive itself has phase 0).
    """
    p = PAPER_SALEH
    out = amplify(np.ones(16, complex), backoff_db)
    r = 10 ** (-backoff_db / 20) / np.sqrt(p["beta_a"])
    a_sat = p["alpha_a"] / (2 * np.sqrt(p["beta_a"]))
    np.testing.assert_allclose(np.abs(out), am_am(r, p["alpha_a"], p["beta_a"]) / a_sat, rtol=1e-12)
    np.testing.assert_allclose(np.angle(out), am_pm(r, p["alpha_phi"], p["beta_phi"]), rtol=1e-12)


def test_saleh_saturation_gives_unit_amplitude_and_is_the_maximum() -> None:
    """At 0 dB backoff the output amplitude is exactly 1 and is the largest A can reach.

    Theory: dA/dr = alpha_a (1 - beta_a r^2) / (1 + beta_a r^2)^2 vanishes at r_sat, so 1 is the
    AM/AM maximum; any other drive level, below or above saturation, gives less. The AM/PM phase
    there is alpha_phi r_sat^2 / (1 + beta_phi r_sat^2) with r_sat^2 = 1 / beta_a.
    """
    p = PAPER_SALEH
    env = np.array([0.5, 0.9, 1.0, 1.1, 2.0], complex)  # drive relative to the saturating input
    out = amplify(env, 0.0)
    amp = np.abs(out)
    assert amp[2] == pytest.approx(1.0, abs=1e-12)
    assert np.all(np.delete(amp, 2) < 1.0)
    r_sat2 = 1.0 / p["beta_a"]
    phase_sat = p["alpha_phi"] * r_sat2 / (1.0 + p["beta_phi"] * r_sat2)
    assert np.angle(out[2]) == pytest.approx(phase_sat, abs=1e-12)


def test_saleh_compression_grows_towards_saturation() -> None:
    """Gain compression, in dB, shrinks as the backoff grows (eq. 3: A ~ alpha_a r for small r).

    Compared against eq. 3: output power minus input power, relative to the small-signal gain
    alpha_a, is -20 log10(1 + beta_a r^2), which goes to 0 dB at large backoff.
    """
    p = PAPER_SALEH
    backoffs = np.array([0.0, 3.0, 10.0, 30.0])
    a_sat = p["alpha_a"] / (2 * np.sqrt(p["beta_a"]))
    compression = []
    for b in backoffs:
        out = amplify(np.ones(4, complex), float(b))
        r = 10 ** (-b / 20) / np.sqrt(p["beta_a"])
        gain = np.abs(out[0]) * a_sat / r  # back to the un-normalised amplifier voltage gain
        compression.append(20 * np.log10(gain / p["alpha_a"]))
    expected = -20 * np.log10(1 + 10 ** (-backoffs / 10))  # beta_a r^2 = 10^(-backoff/10)
    np.testing.assert_allclose(compression, expected, atol=1e-10)
    assert np.all(np.diff(compression) > 0)
    assert compression[0] == pytest.approx(-20 * np.log10(2.0), abs=1e-10)  # 6.02 dB at r_sat


def test_saleh_acts_on_shaped_drive_and_keeps_its_phase() -> None:
    """A shaped, phase-modulated drive: each sample follows eq. 3-4 at its own amplitude and
    the amplifier adds Phi(r) to the drive phase (an LFM-like quadratic phase here)."""
    p = PAPER_SALEH
    n = np.arange(64)
    drive_amp = 0.2 + 0.8 * np.sin(np.pi * (n + 0.5) / 64)  # smooth, peak near 1
    drive_phase = 0.01 * (n - 32.0) ** 2
    env = drive_amp * np.exp(1j * drive_phase)
    backoff = 2.0
    out = amplify(env, backoff)
    r = drive_amp * 10 ** (-backoff / 20) / np.sqrt(p["beta_a"])
    a_sat = p["alpha_a"] / (2 * np.sqrt(p["beta_a"]))
    expected = (
        am_am(r, p["alpha_a"], p["beta_a"])
        / a_sat
        * np.exp(1j * (drive_phase + am_pm(r, p["alpha_phi"], p["beta_phi"])))
    )
    np.testing.assert_allclose(out, expected, rtol=1e-12, atol=1e-14)


def test_saleh_with_other_parameters() -> None:
    """The normalisation follows the parameters (not the paper's numbers baked in): with
    alpha_a = 1, beta_a = 4 the saturating drive is 0.5 and A(r_sat) = 1/4."""
    params = {"alpha_a": 1.0, "beta_a": 4.0, "alpha_phi": 0.5, "beta_phi": 1.0}
    out = amplify(np.ones(3, complex), 6.0, **params)
    r = 10 ** (-6.0 / 20) * 0.5
    assert np.abs(out[0]) == pytest.approx(am_am(r, 1.0, 4.0) / 0.25, rel=1e-12)
    assert np.angle(out[0]) == pytest.approx(am_pm(r, 0.5, 1.0), rel=1e-12)
