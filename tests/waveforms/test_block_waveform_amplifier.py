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

import itertools

import numpy as np
import pytest
from pasim_blocks.transmitters.amplifiers import IdealAmplifier, SalehAmplifier
from pasim_blocks.waveforms.pulses import RectangularPulse, pulse_dataset

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


# --- Swept waveforms, file waveforms and the Rapp amplifier -------------------------------
#
# What these compare against: the LFM's definition (phase pi (B/T) t^2, so the phase step
# between samples is exactly the sweep at the interval's midpoint); scipy.signal.windows for
# the transmit windows; the closed-form stationary-phase law of a truncated Gaussian density,
# written with scipy.stats.norm (f(t) = sigma B Phi^-1(Phi(-1/(2 sigma)) + (t/T)(Phi(1/(2
# sigma)) - Phi(-1/(2 sigma))))); the Gaussian density itself for the NLFM's spectrum; the
# Tukey taper's power efficiency 1 - 5 a / 8; Rapp's formula (Rapp 1991) written out here.

B_HZ, T_S = 3.6e6, 50e-6  # paper section 2.3


def make(cls, **params):
    block = cls(name="tx", **params)
    return block.process({}, Chunk(beams=np.arange(0), resource=block.load()))["pulse"]


def inst_frequency(env: np.ndarray, fs: float) -> np.ndarray:
    """Mean frequency over each sample interval, from the phase step."""
    return np.angle(env[1:] * np.conj(env[:-1])) * fs / (2 * np.pi)


@pytest.mark.parametrize(("oversampling", "rate"), [(2.0, None), (3.0, None), (2.0, 5e6)])
def test_lfm_sweeps_the_band_linearly(oversampling: float, rate: float | None) -> None:
    """Constant amplitude, and the phase step between samples is slope x (interval midpoint)
    with slope B / T (exact for a quadratic phase), sweeping -B/2 to +B/2; the rate is the
    one given, else oversampling x bandwidth."""
    from pasim_blocks.waveforms.pulses import LinearFM

    pulse = make(LinearFM, oversampling=oversampling, sample_rate_hz=rate)
    fs = rate if rate is not None else oversampling * B_HZ
    env = pulse["envelope"].values
    assert pulse.attrs["sample_rate_hz"] == pytest.approx(fs)
    assert env.size == round(T_S * fs)
    np.testing.assert_allclose(np.abs(env), 1.0, atol=1e-12)
    n = env.size
    t_mid = (np.arange(n - 1) + 1 - n / 2) / fs  # midpoints between centred sample times
    np.testing.assert_allclose(inst_frequency(env, fs), B_HZ / (n / fs) * t_mid, atol=1e-6 * B_HZ)
    assert pulse.attrs["bandwidth_hz"] == B_HZ
    assert pulse.attrs["width_s"] == pytest.approx(n / fs)


@pytest.mark.parametrize(
    ("window", "params"),
    [
        ("taylor", {"taylor_sidelobe_db": -60.0, "taylor_nbar": 10}),
        ("taylor", {"taylor_sidelobe_db": -35.0, "taylor_nbar": 4}),
        ("tukey", {"tukey_fraction": 0.25}),
    ],
)
def test_lfm_window_is_scipys(window: str, params: dict) -> None:
    """The envelope's amplitude is scipy.signal.windows' window (peak 1) and its phase the
    plain LFM's."""
    import scipy.signal.windows as windows
    from pasim_blocks.waveforms.pulses import LinearFM

    plain = make(LinearFM)["envelope"].values
    env = make(LinearFM, window=window, **params)["envelope"].values
    n = env.size
    if window == "taylor":
        w = windows.taylor(n, nbar=params["taylor_nbar"], sll=-params["taylor_sidelobe_db"])
    else:
        w = windows.tukey(n, params["tukey_fraction"])
    np.testing.assert_allclose(np.abs(env), w / w.max(), atol=1e-12)
    on = w > 0
    np.testing.assert_allclose(env[on] / np.abs(env[on]), plain[on], atol=1e-12)


def test_sample_rate_below_bandwidth_is_a_named_problem() -> None:
    """check_config refuses a complex sample rate below the bandwidth (Nyquist), naming the
    parameter; 1.5x is allowed when given explicitly."""
    from pasim_blocks.waveforms.pulses import LinearFM, NonlinearFM

    for cls in (LinearFM, NonlinearFM):
        problems = cls.check_config({"sample_rate_hz": 3.0e6}, set())
        assert problems and problems[0][0] == "parameter 'sample_rate_hz'"
        assert "below the bandwidth" in problems[0][1]
        assert cls.check_config({"sample_rate_hz": 5.4e6}, set()) == []
        assert cls.check_config({}, set()) == []


@pytest.mark.parametrize("sigma", [0.12, 0.15, 0.3])
def test_gaussian_nlfm_follows_the_stationary_phase_law(sigma: float) -> None:
    """Constant envelope, and the frequency law is the closed form of a Gaussian density
    truncated to the band (scipy.stats.norm), within 0.5 % of B (the phase step is the mean
    over a sample interval, which departs from the midpoint value where the law is steep)."""
    from pasim_blocks.waveforms.pulses import NonlinearFM
    from scipy.stats import norm

    pulse = make(NonlinearFM, design="gaussian", density_std_fraction=sigma)
    env = pulse["envelope"].values
    fs = pulse.attrs["sample_rate_hz"]
    np.testing.assert_allclose(np.abs(env), 1.0, atol=1e-12)
    n = env.size
    u = np.arange(1, n) / n  # the intervals' midpoints in pulse fractions
    lo, hi = norm.cdf(-0.5 / sigma), norm.cdf(0.5 / sigma)
    expected = sigma * B_HZ * norm.ppf(lo + u * (hi - lo))
    np.testing.assert_allclose(inst_frequency(env, fs), expected, atol=5e-3 * B_HZ)


def test_gaussian_nlfm_spectrum_is_the_density() -> None:
    """Stationary phase: the power spectrum of the NLFM is the Gaussian density it was
    designed from. Both averaged over 0.05 B wide bins (the Fresnel ripple averages out), the
    spectrum is within 1 dB of the density where the density is above -13 dB. Further out the
    sweep is fast and stationary phase only approximate: in the two outermost bins (density
    -13.4 and -17.2 dB) the spectrum is 1.8 and 1.9 dB below it."""
    from pasim_blocks.waveforms.pulses import NonlinearFM

    sigma = 0.15
    pulse = make(NonlinearFM, design="gaussian", density_std_fraction=sigma)
    env, fs = pulse["envelope"].values, pulse.attrs["sample_rate_hz"]
    n_fft = 1 << 16
    spec = np.abs(np.fft.fft(env, n_fft)) ** 2
    f = np.fft.fftfreq(n_fft, 1 / fs) / B_HZ
    density = np.exp(-(f**2) / (2 * sigma**2))
    edges = np.arange(-0.5, 0.5001, 0.05)
    bins = [(f >= a) & (f < b) for a, b in itertools.pairwise(edges)]
    measured = np.array([spec[k].mean() for k in bins])
    density = np.array([density[k].mean() for k in bins])
    keep = density > 0.05
    m = 10 * np.log10(measured[keep] / measured[keep].max())
    d = 10 * np.log10(density[keep])
    np.testing.assert_allclose(m - m.max(), d - d.max(), atol=1.0)


def test_optimised_nlfm_is_the_shipped_design() -> None:
    """The optimised design's envelope has the shipped Tukey taper: its power efficiency is
    1 - 5 a / 8 (theory of the Tukey window, to the sampling), and the block's pulse is the
    design module's envelope."""
    from pasim_blocks.waveforms.nlfm import load_optimised, optimised_envelope
    from pasim_blocks.waveforms.pulses import NonlinearFM

    design = load_optimised()
    pulse = make(NonlinearFM, design="optimised")
    env, fs = pulse["envelope"].values, pulse.attrs["sample_rate_hz"]
    np.testing.assert_allclose(env, optimised_envelope(design, B_HZ, T_S, fs), atol=1e-12)
    a = design["taper_fraction"]
    assert np.mean(np.abs(env) ** 2) == pytest.approx(1 - 5 * a / 8, abs=2e-3)


def test_optimised_nlfm_at_another_time_bandwidth_says_so() -> None:
    """The optimum holds for the design's time-bandwidth product; another one runs with a
    note."""
    from pasim_blocks.waveforms.pulses import NonlinearFM

    from pasim_graph import RunNote

    with pytest.warns(RunNote, match="time-bandwidth product"):
        make(NonlinearFM, design="optimised", width_s=20e-6)


def test_file_waveform_round_trip(tmp_path) -> None:
    """An .npz with envelope and sample_rate_hz comes back scaled to peak 1, same shape and
    phase, at its sample rate; bandwidth_hz is passed on when the file has it."""
    from pasim_blocks.waveforms.pulses import FileWaveform

    rng = np.random.default_rng(5)
    env = (rng.standard_normal(50) + 1j * rng.standard_normal(50)) * 3.0
    path = tmp_path / "pulse.npz"
    np.savez(path, envelope=env, sample_rate_hz=4e6, bandwidth_hz=2e6)
    pulse = make(FileWaveform, path=str(path))
    np.testing.assert_allclose(pulse["envelope"].values, env / np.abs(env).max(), rtol=1e-12)
    assert pulse.attrs["sample_rate_hz"] == 4e6
    assert pulse.attrs["bandwidth_hz"] == 2e6
    assert pulse.attrs["width_s"] == pytest.approx(50 / 4e6)


@pytest.mark.parametrize(
    ("contents", "words"),
    [
        ({"sample_rate_hz": 1e6}, ["no 'envelope'", "holds: sample_rate_hz"]),
        ({"envelope": np.ones(8)}, ["no 'sample_rate_hz'"]),
        ({"envelope": np.ones((2, 8)), "sample_rate_hz": 1e6}, ["1-D array", "(2, 8)"]),
        ({"envelope": np.ones(1), "sample_rate_hz": 1e6}, ["at least 2"]),
        ({"envelope": np.array([1.0, np.nan]), "sample_rate_hz": 1e6}, ["finite"]),
        ({"envelope": np.zeros(4), "sample_rate_hz": 1e6}, ["not all zero"]),
        ({"envelope": np.ones(4), "sample_rate_hz": -1.0}, ["sample_rate_hz must be one positive"]),
    ],
)
def test_file_waveform_bad_contents_are_named(tmp_path, contents: dict, words: list) -> None:
    """load() refuses a file without the two arrays, or with bad ones, saying which."""
    from pasim_blocks.waveforms.pulses import FileWaveform

    path = tmp_path / "bad.npz"
    np.savez(path, **contents)
    with pytest.raises(ValueError) as info:
        FileWaveform(name="tx", path=str(path)).load()
    for w in [str(path), *words]:
        assert w in str(info.value)


def test_file_waveform_not_npz(tmp_path) -> None:
    from pasim_blocks.waveforms.pulses import FileWaveform

    path = tmp_path / "pulse.npz"
    path.write_text("not a numpy archive")
    with pytest.raises(ValueError, match="cannot read waveform file"):
        FileWaveform(name="tx", path=str(path)).load()


def rapp_formula(r: np.ndarray, p: float) -> np.ndarray:
    """Rapp (1991) AM/AM, written out here: r / (1 + r^(2p))^(1/(2p))."""
    return r * (1.0 + r ** (2 * p)) ** (-1.0 / (2 * p))


@pytest.mark.parametrize("p", [1.0, 2.0, 3.0, 10.0])
@pytest.mark.parametrize("backoff_db", [-6.0, 0.0, 3.0, 20.0])
def test_rapp_follows_its_formula_and_keeps_the_phase(p: float, backoff_db: float) -> None:
    """A shaped, phase-modulated drive: each sample's amplitude follows Rapp's AM/AM at its
    own drive level (peak 10^(-backoff/20) of the saturation input) and its phase is
    unchanged (the model has no AM/PM)."""
    from pasim_blocks.transmitters.amplifiers import RappAmplifier

    n = np.arange(64)
    amp = 0.05 + 0.95 * np.sin(np.pi * (n + 0.5) / 64)
    env = amp * np.exp(1j * 0.01 * (n - 32.0) ** 2)
    block = RappAmplifier(name="hpa", smoothness=p, input_backoff_db=backoff_db)
    out = block.process({"pulse_in": pulse_dataset(env, 20e6)}, NO_BEAMS)["pulse"]
    out = out["envelope"].values
    r = amp * 10 ** (-backoff_db / 20)
    np.testing.assert_allclose(np.abs(out), rapp_formula(r, p), rtol=1e-12)
    np.testing.assert_allclose(np.angle(out * np.conj(env)), 0.0, atol=1e-12)


def test_rapp_limits() -> None:
    """Theory: at the saturation input the output is 2^(-1/(2p)) (3.01/p dB below the rated
    power); the small-signal gain is 1; as p grows the model becomes a hard limiter
    min(r, 1); the output never exceeds the saturation level."""
    from pasim_blocks.transmitters.amplifiers import RappAmplifier

    def out(env: np.ndarray, **kw: float) -> np.ndarray:
        block = RappAmplifier(name="hpa", **kw)
        res = block.process({"pulse_in": pulse_dataset(env, 1e6)}, NO_BEAMS)["pulse"]
        return np.abs(res["envelope"].values)

    for p in (1.0, 2.0, 5.0):
        assert out(np.ones(2, complex), smoothness=p)[0] == pytest.approx(2 ** (-1 / (2 * p)))
        assert 20 * np.log10(out(np.ones(2, complex), smoothness=p)[0]) == pytest.approx(
            -10 * np.log10(2) / p
        )
    small = out(np.ones(2, complex), smoothness=2.0, input_backoff_db=40.0)[0]
    assert small == pytest.approx(10 ** (-40 / 20), rel=1e-7)
    r = np.linspace(0.0, 3.0, 61)
    env = r.astype(complex)
    hard = out(env, smoothness=100.0)
    np.testing.assert_allclose(hard, np.minimum(r, 1.0), atol=4e-3)
    assert np.all(out(env * 10, smoothness=0.5, input_backoff_db=-20.0) <= 1.0)
