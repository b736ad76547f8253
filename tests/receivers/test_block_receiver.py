"""Tests of the receiver block (``blocks/receiver.py``).

What each test compares against:

* noise power: theory, k T0 F B with Boltzmann's constant from scipy.constants, T0 = 290 K, F
  from the noise figure and B from the range_response attributes;
* circularity and independence of the noise: the statistics of circular complex white
  Gaussian noise (I and Q variance N/2 each, uncorrelated; H and V uncorrelated);
* the echo: linearity (output = echo + noise, the same noise realisation for the same
  stream);
* chunking: the definition of per-beam random streams (``Chunk.rng``).

Statistical tolerances: with n independent complex samples, |noise|^2 is exponential (std =
mean), so its sample mean has relative standard error 1/sqrt(n); sample variances of I and
of Q each have relative standard error sqrt(2/n); a sample correlation coefficient of
independent variables has standard error 1/sqrt(n). Every check uses 5 standard errors
(false-alarm probability below 1e-6 per check; the seed is fixed anyway).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.constants
import xarray as xr
from pasim_blocks.receivers.receiver import Receiver

from pasim_graph import Chunk

BANDWIDTH_HZ = 625e3  # 1 / 1.6 us, the generic radar's rectangular pulse
N_BEAMS, N_GATES, N_PULSES = 4, 200, 64
N_SAMPLES = N_BEAMS * N_GATES * N_PULSES  # per channel


def range_response(bandwidth_hz: float = BANDWIDTH_HZ) -> xr.Dataset:
    """A range_response as the matched filter gives it; the receiver reads the bandwidth."""
    x = np.array([-1.0, 0.0, 1.0])
    return xr.Dataset(
        {"power_weight": ("offset", [0.0, 1.0, 0.0])},
        coords={"offset_m": ("offset", x)},
        attrs={"noise_bandwidth_hz": bandwidth_hz, "sample_rate_hz": 20e6},
    )


def run(
    echo: np.ndarray,
    beams: np.ndarray | None = None,
    seed: int = 11,
    options: dict | None = None,
    bandwidth_hz: float = BANDWIDTH_HZ,
    **params: float,
) -> dict:
    block = Receiver(name="rx", **params)
    chunk = Chunk(
        beams=np.arange(echo.shape[0]) if beams is None else beams,
        seed=seed,
        block_name="rx",
        options=options or {},
    )
    return block.process({"iq_in": echo, "range_response": range_response(bandwidth_hz)}, chunk)


def zeros() -> np.ndarray:
    return np.zeros((N_BEAMS, N_GATES, N_PULSES, 2), np.complex64)


def ktfb(noise_figure_db: float, bandwidth_hz: float = BANDWIDTH_HZ) -> float:
    return scipy.constants.k * 290.0 * 10 ** (noise_figure_db / 10) * bandwidth_hz


@pytest.mark.parametrize(("nf_db", "bw_hz"), [(2.7, BANDWIDTH_HZ), (6.0, 3.6e6)])
def test_noise_power_is_k_t0_f_b(nf_db: float, bw_hz: float) -> None:
    """Reported and measured noise power per channel = k T0 F B (theory)."""
    out = run(zeros(), noise_figure_db=nf_db, bandwidth_hz=bw_hz)
    expected = ktfb(nf_db, bw_hz)
    np.testing.assert_allclose(out["noise_power"], expected, rtol=1e-6)
    assert out["noise_power"].shape == (N_BEAMS, N_GATES, 2)
    iq = out["iq"].astype(np.complex128)
    tol = 5 / np.sqrt(N_SAMPLES)
    for pol in range(2):
        measured = np.mean(np.abs(iq[..., pol]) ** 2)
        assert measured == pytest.approx(expected, rel=tol), f"channel {pol}"


def test_noise_is_circular() -> None:
    """I and Q each carry half the noise power and are uncorrelated (circular noise)."""
    out = run(zeros())
    iq = out["iq"].astype(np.complex128)
    n = ktfb(2.7)
    for pol in range(2):
        i, q = iq[..., pol].real.ravel(), iq[..., pol].imag.ravel()
        for part in (i, q):
            assert np.mean(part) == pytest.approx(0.0, abs=5 * np.sqrt(n / 2 / N_SAMPLES))
            assert np.var(part) == pytest.approx(n / 2, rel=5 * np.sqrt(2 / N_SAMPLES))
        assert abs(np.corrcoef(i, q)[0, 1]) < 5 / np.sqrt(N_SAMPLES)
        # Pseudo-covariance E[n^2] = var I - var Q + 2j cov(I, Q) vanishes for circular noise.
        pseudo = np.mean(iq[..., pol] ** 2) / n
        assert abs(pseudo) < 5 * np.sqrt(2) / np.sqrt(N_SAMPLES)


def test_noise_is_independent_between_channels_and_white() -> None:
    """H and V noise are uncorrelated; within a channel, neighbouring pulses and gates too.

    |complex correlation| of independent circular samples is Rayleigh with scale
    1/sqrt(2 n); 5/sqrt(n) is more than 7 of its scales.
    """
    out = run(zeros())
    iq = out["iq"].astype(np.complex128)
    h, v = iq[..., 0], iq[..., 1]

    def corr(a: np.ndarray, b: np.ndarray) -> float:
        power = np.sqrt(np.mean(np.abs(a) ** 2) * np.mean(np.abs(b) ** 2))
        return float(np.abs(np.mean(a * np.conj(b))) / power)

    assert corr(h, v) < 5 / np.sqrt(h.size)
    lag_pulse = h[:, :, 1:], h[:, :, :-1]
    assert corr(*lag_pulse) < 5 / np.sqrt(lag_pulse[0].size)
    lag_gate = h[:, 1:], h[:, :-1]
    assert corr(*lag_gate) < 5 / np.sqrt(lag_gate[0].size)
    lag_beam = h[1:], h[:-1]
    assert corr(*lag_beam) < 5 / np.sqrt(lag_beam[0].size)


def test_echo_passes_and_noise_adds() -> None:
    """Output = echo + noise: with the same stream, (out with echo) - (out without) = echo."""
    rng = np.random.default_rng(3)
    echo = (rng.standard_normal(zeros().shape) + 1j * rng.standard_normal(zeros().shape)) * 1e-6
    echo = echo.astype(np.complex64)
    with_echo = run(echo)["iq"]
    without = run(zeros())["iq"]
    np.testing.assert_allclose(with_echo - without, echo, rtol=0, atol=1e-11)
    assert with_echo.dtype == np.complex64
    assert with_echo.shape == echo.shape


def test_iq_store_only_when_saving_iq() -> None:
    """``iq_store`` exists only when the run option ``save_iq`` is true, and then holds the
    output H and V cubes on (beam, range, pulse)."""
    assert "iq_store" not in run(zeros())
    assert "iq_store" not in run(zeros(), options={"save_iq": False})
    out = run(zeros(), options={"save_iq": True})
    store = out["iq_store"]
    assert set(store.data_vars) == {"IQ_H", "IQ_V"}
    for k, name in enumerate(("IQ_H", "IQ_V")):
        assert store[name].dims == ("beam", "range", "pulse")
        np.testing.assert_array_equal(store[name].values, out["iq"][..., k])
        assert store[name].attrs["units"] == "sqrt(W)"


def test_noise_does_not_depend_on_chunking() -> None:
    """A beam's noise comes from its own stream (seed, block name, beam index): processing
    beams 10..13 as one chunk of 4 or as four chunks of 1 gives identical numbers."""
    beams = np.arange(10, 14)
    together = run(zeros(), beams=beams)["iq"]
    for i, b in enumerate(beams):
        alone = run(zeros()[:1], beams=np.array([b]))["iq"]
        np.testing.assert_array_equal(alone[0], together[i])
    # Different beams and different run seeds give different noise.
    assert not np.allclose(together[0], together[1])
    other_seed = run(zeros(), beams=beams, seed=12)["iq"]
    assert not np.allclose(other_seed, together)


def test_fixed_snr_sets_noise_per_gate_from_the_echo_power() -> None:
    """With snr_db, noise = expected H echo power / SNR at each gate, the same in V (so V's SNR
    is lower by ZDR), and the thermal value where there is no echo (definition)."""
    signal = np.zeros((N_BEAMS, N_GATES, 2), np.float32)
    signal[..., 0] = np.linspace(1e-10, 1e-8, N_GATES)[None, :]
    signal[..., 1] = signal[..., 0] / 10**0.1
    signal[:, :5] = 0.0
    block = Receiver(name="rx", snr_db=20.0)
    out = block.process(
        {"iq_in": zeros(), "range_response": range_response(BANDWIDTH_HZ), "signal_power": signal},
        Chunk(beams=np.arange(N_BEAMS), seed=11, block_name="rx"),
    )
    noise = out["noise_power"]
    np.testing.assert_allclose(noise[:, 5:, 0], signal[:, 5:, 0] / 100, rtol=1e-6)
    np.testing.assert_allclose(noise[..., 1], noise[..., 0])
    np.testing.assert_allclose(noise[:, :5], ktfb(2.7), rtol=1e-6)
    measured = np.mean(np.abs(out["iq"][..., 0]) ** 2, axis=2)
    assert np.median(measured[:, 5:] / noise[:, 5:, 0]) == pytest.approx(1.0, abs=0.05)


def test_fixed_snr_without_signal_power_is_a_validation_error() -> None:
    problems = Receiver.check_config({"snr_db": 10.0}, {"iq_in", "range_response"})
    assert problems and "signal_power" in problems[0][1]
    assert Receiver.check_config({}, {"iq_in", "range_response"}) == []
