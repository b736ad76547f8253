"""Tests of the matched filter block (``blocks/matched_filter.py``).

What each test compares against:

* rectangular pulse of width tau: theory. The matched-filter output is a triangle in range,
  so the range weighting |y|^2 is a squared triangle (1 - |x| / (c tau / 2))^2: peak 1 at
  offset 0, zero beyond +-c tau / 2, half voltage at +-c tau / 4, integral (2/3)(c tau / 2);
* noise bandwidth: theory (B = 1/tau for a rectangular pulse) and a Monte Carlo of white
  noise through the filter built independently here;
* distorted pulses: an independent numpy.correlate of the radiated pulse with the reference,
  and the Saleh equations (paper eq. 3) for the expected loss of peak;
* the sign of the range offset: a fast-time simulation of a point scatterer's echo sampled at
  one gate, written out here, for symmetric and asymmetric (drooping) pulses;
* the SNR loss: 0 for the filter matched to the radiated pulse (Cauchy-Schwarz); for a
  distorted pulse through the filter matched to the ideal one, an independent numpy.correlate;
  for the windowed (mismatched) filter on a constant-envelope LFM, the window's processing
  loss -10 log10((sum w)^2 / (N sum w^2)) from scipy.signal.windows;
* the mismatched filter's sidelobes: a -40 dB Taylor weighting of an LFM of time-bandwidth
  product 180 gives sidelobes near -40 dB (stationary phase: time weighting of an LFM is
  frequency weighting).
"""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.receivers.filters import MatchedFilter
from pasim_blocks.transmitters.amplifiers import SalehAmplifier
from pasim_blocks.waveforms.pulses import RectangularPulse, pulse_dataset

from pasim_graph import Chunk

C = 299_792_458.0  # m/s, written out here rather than taken from the block library
NO_BEAMS = Chunk(beams=np.arange(0))
TAU = 1.6e-6  # paper Table 4 generic radar pulse
FS = 20e6


def response(tx: np.ndarray, ref: np.ndarray, fs: float = FS):
    mf = MatchedFilter(name="mf")
    inputs = {"pulse": pulse_dataset(tx, fs), "reference": pulse_dataset(ref, fs)}
    return mf.process(inputs, NO_BEAMS)["range_response"]


def rect_response(tau: float = TAU, fs: float = FS):
    pulse = RectangularPulse(name="wf", width_s=tau, sample_rate_hz=fs).process({}, NO_BEAMS)
    return response(pulse["pulse"]["envelope"].values, pulse["pulse"]["envelope"].values, fs)


@pytest.mark.parametrize(("tau", "fs"), [(TAU, FS), (1.0e-6, 50e6), (4.0e-6, 5e6)])
def test_rectangular_range_weighting_is_squared_triangle(tau: float, fs: float) -> None:
    """|y|^2 = (1 - |x| / (c tau / 2))^2 at every offset x (theory; exact for a sampled
    rectangle whose width is a whole number of samples)."""
    rr = rect_response(tau, fs)
    x = rr["offset_m"].values
    half = C * tau / 2
    expected = np.clip(1 - np.abs(x) / half, 0, None) ** 2
    np.testing.assert_allclose(rr["power_weight"].values, expected, atol=1e-12)
    # Peak 1 at offset 0.
    i0 = np.argmin(np.abs(x))
    assert x[i0] == pytest.approx(0.0, abs=1e-9)
    assert rr["power_weight"].values[i0] == pytest.approx(1.0, abs=1e-12)
    assert np.argmax(rr["power_weight"].values) == i0
    # Nothing at or beyond +-c tau / 2 (support of the triangle).
    w = rr["power_weight"].values
    assert np.all(np.abs(x[w > 1e-12]) < half)
    # Offsets are spaced by the range sample c / (2 fs).
    np.testing.assert_allclose(np.diff(x), C / (2 * fs), rtol=1e-9)


def test_rectangular_half_voltage_at_quarter_pulse_length() -> None:
    """The voltage response is 1/2 (power 1/4, -6 dB) at +-c tau / 4 (theory)."""
    rr = rect_response()
    x = rr["offset_m"].values
    v = np.abs(rr["voltage"].values)
    for sign in (-1, 1):
        at = np.interp(sign * C * TAU / 4, x, v)
        assert at == pytest.approx(0.5, abs=1e-9)
    w = rr["power_weight"].values
    assert np.interp(C * TAU / 4, x, w) == pytest.approx(0.25, abs=1e-9)


def test_rectangular_range_weighting_integral() -> None:
    """Integral of the squared triangle: (2/3)(c tau / 2), the range-resolution term of the
    radar constant. The sampled sum is (c tau/2)(2 N^2 + 1) / (3 N^2), N = tau fs = 32
    samples, i.e. 5e-4 above the continuous value, hence the 1e-3 tolerance."""
    rr = rect_response()
    dx = C / (2 * FS)
    integral = float(np.sum(rr["power_weight"].values) * dx)
    assert integral == pytest.approx(2 / 3 * C * TAU / 2, rel=1e-3)


def test_noise_bandwidth_is_inverse_pulse_width() -> None:
    """B = fs / sum |ref|^2 = 1/tau for a rectangular pulse (theory)."""
    for tau, fs in [(TAU, FS), (1e-6, 50e6), (4e-6, 5e6)]:
        rr = rect_response(tau, fs)
        assert rr.attrs["noise_bandwidth_hz"] == pytest.approx(1 / tau, rel=1e-9)


def test_noise_bandwidth_by_monte_carlo() -> None:
    """White noise of density N0 (per-sample variance N0 fs) through h = conj(ref reversed) /
    sum|ref|^2 comes out with power N0 B. Checked by filtering K independent noise records
    here (one output sample each, so the K outputs are independent): the mean of |y|^2 is an
    exponential-variable mean with relative standard error 1/sqrt(K); tolerance 5/sqrt(K)."""
    n = round(TAU * FS)
    ref = np.hanning(n + 2)[1:-1].astype(complex)  # any reference: here a tapered one
    rr = response(ref, ref)
    k = 20_000
    n0 = 1e-3
    rng = np.random.default_rng(2024)
    noise = (rng.standard_normal((k, n)) + 1j * rng.standard_normal((k, n))) * np.sqrt(n0 * FS / 2)
    h = np.conj(ref[::-1]) / np.sum(np.abs(ref) ** 2)
    y = noise @ h[::-1]  # the filter output at the sample where the whole filter overlaps
    measured = float(np.mean(np.abs(y) ** 2)) / n0
    assert measured == pytest.approx(rr.attrs["noise_bandwidth_hz"], rel=5 / np.sqrt(k))
    # And the attribute equals fs sum |h|^2 (the same quantity from the filter taps).
    assert rr.attrs["noise_bandwidth_hz"] == pytest.approx(FS * np.sum(np.abs(h) ** 2), rel=1e-12)


def test_scaled_pulse_lowers_peak_by_the_square() -> None:
    """A radiated pulse at half amplitude: y halves, so |y|^2 peaks at 0.25 (independent
    numpy.correlate of the two envelopes)."""
    n = round(TAU * FS)
    ref = np.ones(n, complex)
    rr = response(0.5 * ref, ref)
    y = np.correlate(0.5 * ref, ref, mode="full") / np.sum(np.abs(ref) ** 2)
    np.testing.assert_allclose(rr["power_weight"].values, np.abs(y) ** 2, atol=1e-12)
    assert float(rr["power_weight"].max()) == pytest.approx(0.25, abs=1e-12)


@pytest.mark.parametrize("backoff_db", [0.0, 3.0, 10.0])
def test_saleh_distorted_pulse_peak(backoff_db: float) -> None:
    """A rectangular pulse through the Saleh HPA is still rectangular with amplitude
    A(r)/A(r_sat) = 2 x / (1 + x^2), x = 10^(-backoff/20), and a constant phase, so the
    matched-filter peak is (A(r)/A(r_sat))^2: 1, 0.89 and 0.33 at 0, 3 and 10 dB backoff (eq. 3
    evaluated here). The whole weighting is compared with numpy.correlate."""
    n = round(TAU * FS)
    ref = np.ones(n, complex)
    hpa = SalehAmplifier(name="hpa", input_backoff_db=backoff_db)
    tx = hpa.process({"pulse_in": pulse_dataset(ref, FS)}, NO_BEAMS)["pulse"]["envelope"].values
    rr = response(tx, ref)
    alpha_a, beta_a = 2.1587, 1.1517
    r = 10 ** (-backoff_db / 20) / np.sqrt(beta_a)
    amp = (alpha_a * r / (1 + beta_a * r**2)) / (alpha_a / (2 * np.sqrt(beta_a)))
    assert float(rr["power_weight"].max()) == pytest.approx(amp**2, rel=1e-9)
    y = np.correlate(tx, ref, mode="full") / np.sum(np.abs(ref) ** 2)
    np.testing.assert_allclose(rr["power_weight"].values, np.abs(y) ** 2, atol=1e-12)
    # The noise bandwidth depends on the reference (the filter) only.
    assert rr.attrs["noise_bandwidth_hz"] == pytest.approx(1 / TAU, rel=1e-9)


def test_mismatched_sample_rates_are_refused() -> None:
    """Pulse and reference must share a sample rate (else the lags mean nothing)."""
    with pytest.raises(ValueError, match="sample rate"):
        MatchedFilter(name="mf").process(
            {
                "pulse": pulse_dataset(np.ones(4, complex), 10e6),
                "reference": pulse_dataset(np.ones(8, complex), 20e6),
            },
            NO_BEAMS,
        )


def fast_time_weight(tx: np.ndarray, ref: np.ndarray, delay: int) -> float:
    """|matched-filter output|^2 at one gate for a unit point scatterer ``delay`` samples
    beyond the gate (range offset = delay c / (2 fs), scatterer minus gate).

    The receiver samples the correlation with the reference starting at the gate's time t_g,
    so a scatterer at the gate (delay 0) of an undistorted pulse gives the peak.
    """
    n_rx = 4 * (tx.size + ref.size) + abs(delay)
    t_g = n_rx // 2
    echo = np.zeros(n_rx, complex)
    echo[t_g + delay : t_g + delay + tx.size] = tx  # round trip: the echo starts at t_g + delay
    z = np.sum(echo[t_g : t_g + ref.size] * np.conj(ref)) / np.sum(np.abs(ref) ** 2)
    return float(np.abs(z) ** 2)


def test_symmetric_pulse_offsets_agree_with_fast_time_simulation() -> None:
    """For a symmetric radiated pulse (Saleh-distorted rectangle) the weighting at each offset
    equals the fast-time simulation of a point scatterer at that offset."""
    n = round(TAU * FS)
    ref = np.ones(n, complex)
    hpa = SalehAmplifier(name="hpa", input_backoff_db=3.0)
    tx = hpa.process({"pulse_in": pulse_dataset(ref, FS)}, NO_BEAMS)["pulse"]["envelope"].values
    rr = response(tx, ref)
    x, w = rr["offset_m"].values, rr["power_weight"].values
    for d in range(-(n + 2), n + 3):
        expected = fast_time_weight(tx, ref, d)
        got = np.interp(d * C / (2 * FS), x, w, left=0.0, right=0.0)
        assert got == pytest.approx(expected, abs=1e-12)


def test_asymmetric_pulse_offsets_agree_with_fast_time_simulation() -> None:
    """An HPA with linear droop (amplitude 1 -> 0.6 across the pulse): the weighting of a
    scatterer beyond the gate must equal the fast-time simulation. E.g. 10 samples (75 m)
    beyond the gate the simulation gives 0.256 but the block's weight there is 0.353, the
    value for 75 m in front of the gate."""
    n = round(TAU * FS)
    ref = np.ones(n, complex)
    tx = np.linspace(1.0, 0.6, n).astype(complex)
    rr = response(tx, ref)
    x, w = rr["offset_m"].values, rr["power_weight"].values
    for d in (-20, -10, -3, 3, 10, 20):
        expected = fast_time_weight(tx, ref, d)
        got = np.interp(d * C / (2 * FS), x, w, left=0.0, right=0.0)
        assert got == pytest.approx(expected, abs=1e-9), f"delay {d} samples"


# --- SNR loss and the mismatched (windowed) filter ----------------------------------------


def lfm(fs: float = 7.2e6, band: float = 3.6e6, width: float = 50e-6) -> np.ndarray:
    n = round(width * fs)
    t = (np.arange(n) - (n - 1) / 2) / fs
    return np.exp(1j * np.pi * band / (n / fs) * t**2)


def mismatched(tx: np.ndarray, ref: np.ndarray, fs: float = 7.2e6, **params):
    from pasim_blocks.receivers.filters import MismatchedFilter

    inputs = {
        "pulse": pulse_dataset(tx, fs),
        "reference": pulse_dataset(ref, fs, bandwidth_hz=3.6e6),
    }
    return MismatchedFilter(name="mf", **params).process(inputs, NO_BEAMS)["range_response"]


def test_snr_loss_of_matched_filters() -> None:
    """Matched to the radiated pulse: loss 0. Matched to the ideal pulse while a Saleh HPA
    distorts a Taylor-windowed one: the loss of peak SNR, -10 log10(max|s (x) r|^2 /
    (E_s E_r)), from numpy.correlate here."""
    import scipy.signal.windows as windows

    ref = lfm() * windows.taylor(360, nbar=10, sll=60)
    hpa = SalehAmplifier(name="hpa")
    tx = hpa.process({"pulse_in": pulse_dataset(ref, 7.2e6)}, NO_BEAMS)["pulse"]["envelope"].values
    own = response(tx, tx, 7.2e6)
    assert own.attrs["snr_loss_db"] == pytest.approx(0.0, abs=1e-12)
    ideal = response(tx, ref, 7.2e6)
    c = np.correlate(tx, ref, mode="full")
    expected = -10 * np.log10(
        np.max(np.abs(c) ** 2) / (np.sum(np.abs(tx) ** 2) * np.sum(np.abs(ref) ** 2))
    )
    assert ideal.attrs["snr_loss_db"] == pytest.approx(expected, rel=1e-9)
    assert expected > 0.05  # the distortion costs something measurable


@pytest.mark.parametrize(
    ("window", "params"),
    [("taylor", {"taylor_sidelobe_db": -40.0, "taylor_nbar": 5}), ("kaiser", {"kaiser_beta": 6.0})],
)
def test_time_weighted_filter_loss_is_the_windows_processing_loss(
    window: str, params: dict
) -> None:
    """On a constant-envelope LFM, h = conj(s reversed) w gives a peak sum w and noise gain
    sum w^2: loss -10 log10((sum w)^2 / (N sum w^2)), computed from scipy.signal.windows."""
    import scipy.signal.windows as windows

    s = lfm()
    rr = mismatched(s, s, window=window, domain="time", **params)
    n = s.size
    if window == "taylor":
        w = windows.taylor(n, nbar=params["taylor_nbar"], sll=-params["taylor_sidelobe_db"])
    else:
        w = windows.kaiser(n, params["kaiser_beta"])
    expected = -10 * np.log10(np.sum(w) ** 2 / (n * np.sum(w**2)))
    assert rr.attrs["snr_loss_db"] == pytest.approx(expected, rel=1e-6)
    # Scaled so that the reference peaks at 1 at zero offset.
    x, v = rr["offset_m"].values, np.abs(rr["voltage"].values)
    assert v[np.argmin(np.abs(x))] == pytest.approx(1.0, rel=1e-12)
    assert x[np.argmax(v)] == pytest.approx(0.0, abs=1e-6)
    # The noise bandwidth is fs sum |h|^2 of the taps it reports.
    taps = rr["taps"].values
    assert rr.attrs["noise_bandwidth_hz"] == pytest.approx(7.2e6 * np.sum(np.abs(taps) ** 2))


@pytest.mark.parametrize("domain", ["time", "frequency"])
def test_taylor_weighting_brings_lfm_sidelobes_to_the_window_level(domain: str) -> None:
    """-13.3 dB sidelobes of the LFM come down to about the -40 dB of the Taylor window, the
    mainlobe staying at zero offset. Weighting in time: within 2.5 dB (stationary phase, finite
    time-bandwidth product). Weighting in frequency leaves the Fresnel ripple of the LFM's own
    spectrum (TB 180) in the output: -36.7 dB measured, so only -35 dB or lower is asked."""
    from pasim_blocks.waveforms.pulse_compression import sidelobes

    s = lfm()
    dx = C / (2 * 7.2e6)
    matched = sidelobes(response(s, s, 7.2e6)["voltage"].values, dx)["psl_db"]
    assert matched == pytest.approx(-13.26, abs=0.3)
    rr = mismatched(s, s, domain=domain, taylor_sidelobe_db=-40.0, taylor_nbar=5)
    lobes = sidelobes(rr["voltage"].values, dx)
    if domain == "time":
        assert lobes["psl_db"] == pytest.approx(-40.0, abs=2.5)
    else:
        assert -42.5 < lobes["psl_db"] < -35.0
    x = rr["offset_m"].values
    assert x[np.argmax(np.abs(rr["voltage"].values))] == pytest.approx(0.0, abs=1e-6)
    assert 0.5 < rr.attrs["snr_loss_db"] < 1.5  # a Taylor -40 dB window loses about 1 dB


def test_frequency_weighted_filter_agrees_with_fast_time_simulation() -> None:
    """The range weighting of a longer (frequency-weighted) filter at each offset equals the
    fast-time simulation of a point scatterer there: echo starts delay samples after the gate
    time, the filter output sampled where the reference's peak falls."""
    s = lfm(fs=4e6, band=2e6, width=10e-6)
    hpa = SalehAmplifier(name="hpa", input_backoff_db=1.0)
    tx = hpa.process({"pulse_in": pulse_dataset(s * np.hanning(s.size + 2)[1:-1], 4e6)}, NO_BEAMS)
    tx = tx["pulse"]["envelope"].values
    rr = mismatched(tx, s, fs=4e6, domain="frequency", band_hz=2e6)
    taps = rr["taps"].values
    zero = int(np.argmax(np.abs(np.convolve(s, taps))))
    x, w = rr["offset_m"].values, rr["power_weight"].values
    for d in (-30, -7, -1, 0, 2, 11, 40):
        echo = np.zeros(4 * taps.size + 200, complex)
        t_g = echo.size // 2
        echo[t_g + d : t_g + d + tx.size] = tx
        out = np.convolve(echo, taps)[t_g + zero]
        got = np.interp(d * C / (2 * 4e6), x, w, left=0.0, right=0.0)
        assert got == pytest.approx(abs(out) ** 2, abs=1e-12), f"delay {d}"


def test_frequency_weighting_needs_a_band() -> None:
    from pasim_blocks.receivers.filters import MismatchedFilter

    s = lfm()
    inputs = {"pulse": pulse_dataset(s, 7.2e6), "reference": pulse_dataset(s, 7.2e6)}
    with pytest.raises(ValueError, match="band_hz"):
        MismatchedFilter(name="mf", domain="frequency").process(inputs, NO_BEAMS)
