"""The weather channel in fast time: sub-gate scatterers through the pulse and the receive filter.

The range model (``pasim_blocks.weather.fasttime``) collapses pulse -> scatterers -> receive
filter -> gate sampling into a response per gate offset, Doppler order and independent range
component.
These tests hold it against the literal chain, against integrals computed here by other means,
and check the weather channel built on it: adjacent-gate correlation against the continuous
filter's, power against the expected level's, the blind range, float32 dynamic range.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate
import scipy.signal
from pasim_blocks.antennas.pencil import IdealAntenna
from pasim_blocks.scans.ppi import PPISector
from pasim_blocks.weather.channel import WeatherChannel
from pasim_blocks.weather.fasttime import GateSum, range_model

from pasim_graph import Chunk, load
from pasim_graph.executor import LocalExecutor, RunOptions

from ..conftest import GRAPHS
from ..fast_time_signals import LAMBDA, SPEED_OF_LIGHT, lfm, matched, rectangular
from .test_block_weather import uniform_truth

GATE = 250.0


def ideal_inputs(truth, beams, response, pulses=64):
    """Weather-channel inputs with an ideal (sidelobe-free) antenna and the given response."""
    scan = PPISector(name="scan", azimuth_start_deg=100.0, azimuth_stop_deg=140.0, pulses=pulses)
    b = scan.process({"truth": truth}, Chunk(beams=beams))["beams"]
    antenna = IdealAntenna(name="antenna", beamwidth_deg=1.0)
    pattern = antenna.process({"beams": b}, Chunk(beams=beams))["pattern"]
    return {"truth": truth, "beams": b, "pattern": pattern, "range_response": response}


def weather(inputs, beams, method, seed=2, **params):
    block = WeatherChannel(name="weather", method=method, **params)
    return block.process(inputs, Chunk(beams=beams, seed=seed, block_name="weather"))


def literal_gates(response, amplitudes, velocity_ms, per_gate):
    """Gate voltages by the literal chain, on the receiver's sample grid.

    Cell c's scatterers sit on consecutive samples around its centre (``per_gate`` samples to
    a gate); each returns the radiated pulse with the Doppler phase of its cell along the
    pulse (from the pulse centre), the echoes add, the receive filter convolves, and gate c
    samples the filter output where a target at its centre peaks (the matched filter's delay,
    taps - 1 samples).
    """
    p, h = response["transmitted"].values, response["taps"].values
    fs = float(response.attrs["sample_rate_hz"])
    n_cells, _, pulses = amplitudes.shape
    k = np.arange(p.size) - (p.size - 1) / 2
    first = p.size + h.size
    echo = np.zeros((first + per_gate * n_cells + p.size + h.size, pulses), complex)
    for c in range(n_cells):
        shifted = p * np.exp(-2j * np.pi * (2 * velocity_ms[c] / LAMBDA) * k / fs)
        for s in range(per_gate):
            n0 = first + per_gate * c + s - (per_gate - 1) // 2
            echo[n0 : n0 + p.size] += shifted[:, None] * amplitudes[c, s][None, :]
    out = np.stack([np.convolve(echo[:, m], h) for m in range(pulses)], axis=1)
    return out[first + per_gate * np.arange(n_cells) + h.size - 1]


@pytest.mark.parametrize(("floor_db", "tolerance"), [(-150.0, 1e-6), (-80.0, 1e-3)])
def test_collapsed_operator_equals_the_literal_convolution(floor_db, tolerance):
    """Scatterers -> transmitted pulse with Doppler -> taps -> gates, literally and collapsed.

    A 10 us, 3.6 MHz LFM sampled so that a 250 m gate is 15 samples; 12 cells of 15
    scatterers on the sample grid, each cell at its own velocity up to 30 m/s (a phase of
    0.07 rad across the pulse), 3 pulses of random amplitudes. The collapsed model (the
    scatterers rotated into the model's range components, summed by the channel's own
    ``GateSum``) must give the literal gate voltages: to 1e-6 with nothing dropped (-150 dB),
    and with the channel's default -80 dB floor to a relative rms error of 1e-3 (-60 dB).
    """
    per_gate = 15
    fs = SPEED_OF_LIGHT / (2 * GATE / per_gate)
    response = matched(lfm(3.6e6, 10e-6, fs), fs)
    rng = np.random.default_rng(5)
    n_cells, pulses, v_max = 12, 3, 30.0
    velocity = rng.uniform(-v_max, v_max, n_cells)
    x = rng.standard_normal((n_cells, per_gate, pulses, 2)) @ np.array([1, 1j]) / np.sqrt(2)
    literal = literal_gates(response, x, velocity, per_gate)

    model = range_model(response, GATE, LAMBDA, v_max, floor_db=floor_db, n_fine=per_gate)
    assert model.orders > 1  # the Doppler along the pulse is modelled, not ignored
    gates = model.pad + np.arange(n_cells)
    acc = GateSum(model, int(gates[0]), int(gates[-1]), n_cells, pulses, np.complex128)
    # The model's sub-gate scatterers carry amplitude per sqrt(metre); a point's is x/sqrt(dx).
    z = np.einsum("is,csm->cim", model.basis, x)
    factor = np.full(n_cells, np.sqrt(per_gate / GATE))
    acc.add([(z, factor)], model.normalised_velocity(velocity), gates)
    lo, out = acc.voltages()
    assert (lo, out.shape) == (0, (n_cells, pulses))
    err = np.abs(out - literal)
    if floor_db < -100:
        assert err.max() <= tolerance * np.abs(literal).max()
    else:
        assert np.sqrt(np.mean(err**2) / np.mean(np.abs(literal) ** 2)) <= tolerance


def test_rectangular_pulse_weights_are_the_triangle_integrals():
    """Per-gate power weights of the 1.6 us pulse against the squared triangle, by hand.

    W(x) = 1 - |x|/a, a = c tau / 2: the centre gate gets ∫_{-125}^{125} W^2 and each
    neighbour ∫_{125}^{a} W^2 = a/3 (1 - 125/a)^3. The model interpolates the sampled
    triangle (band-limited), so it agrees to 0.5 %; a cell reaches 3 gates, so 3 components.
    """
    response = rectangular()
    model = range_model(response, GATE, LAMBDA, 25.0)
    a = SPEED_OF_LIGHT * 1.6e-6 / 2
    side = a / 3 * (1 - GATE / 2 / a) ** 3
    centre = 2 * a / 3 - 2 * side
    np.testing.assert_array_equal(model.offsets, [-1, 0, 1])
    np.testing.assert_allclose(model.weights(0.0), [side, centre, side], rtol=5e-3)
    assert model.components == 3
    assert model.orders == 1  # 0.002 rad of Doppler phase over 1.6 us changes nothing at 1 %


def direct_gate_weights(response, velocity_ms, offsets, upsample=64):
    """∫ over each gate offset of |y_v|^2, from an FFT-resampled response and the trapezoid rule.

    y_v is the receive filter's output for the transmitted pulse Doppler-shifted by v, computed
    here from ``transmitted`` and ``taps`` (not from the model), zero-padded, resampled by
    ``upsample`` with scipy and integrated over [(d - 1/2) Δ, (d + 1/2) Δ].
    """
    p, h = response["transmitted"].values, response["taps"].values
    fs = float(response.attrs["sample_rate_hz"])
    t = (np.arange(p.size) - (p.size - 1) / 2) / fs
    y = np.convolve(p * np.exp(-2j * np.pi * (2 * velocity_ms / LAMBDA) * t), h)
    pad = y.size
    fine = scipy.signal.resample(
        np.concatenate([np.zeros(pad), y, np.zeros(pad)]), 3 * pad * upsample
    )
    dx = SPEED_OF_LIGHT / (2 * fs)
    # Sample n of y is offset (taps - 1 - n) dx for the matched filter (its delay).
    n = np.arange(fine.size) / upsample - pad
    x = (h.size - 1 - n) * dx
    order = np.argsort(x)
    x, power = x[order], np.abs(fine[order]) ** 2
    out = []
    for d in offsets:
        inside = (x >= (d - 0.5) * GATE) & (x <= (d + 0.5) * GATE)
        out.append(scipy.integrate.trapezoid(power[inside], x[inside]))
    return np.array(out)


def test_lfm_sidelobe_weights_and_range_doppler_coupling():
    """Per-gate power of a 50 us, 3.6 MHz LFM (its -13 dB sidelobes spread over 30 gates) at
    0 and 17 m/s against an independent integral (FFT resampling, trapezoid rule): within 1 %
    wherever above -60 dB of the centre gate. The Doppler along the pulse moves some gates'
    power by more than 3 % at 17 m/s, so a model without it would fail here.
    """
    fs = 5e6
    response = matched(lfm(3.6e6, 50e-6, fs), fs)
    model = range_model(response, GATE, LAMBDA, 25.0)
    assert model.pad >= 30
    for v in (0.0, 17.0):
        direct = direct_gate_weights(response, v, model.offsets)
        mine = model.weights(model.normalised_velocity(v))
        strong = direct > 1e-6 * direct.max()
        np.testing.assert_allclose(mine[strong], direct[strong], rtol=0.01)
    # Without the Doppler along the pulse, the 17 m/s weights would miss by over 3 %.
    still = model.weights(0.0)
    moving = direct_gate_weights(response, 17.0, model.offsets)
    strong = moving > 1e-6 * moving.max()
    assert np.max(np.abs(still[strong] / moving[strong] - 1)) > 0.03


def adjacent_correlation_theory(width_s=1.6e-6, spacing_m=GATE):
    """∫ W(r) W(r - s) dr / ∫ W^2 dr, W the matched filter's triangle of half-width c tau / 2."""
    a = SPEED_OF_LIGHT * width_s / 2

    def w(r):
        return max(0.0, 1 - abs(r) / a)

    num = scipy.integrate.quad(lambda r: w(r) * w(r - spacing_m), -a, a + spacing_m, limit=200)
    den = scipy.integrate.quad(lambda r: w(r) ** 2, -a, a, limit=200)
    return num[0] / den[0]


@pytest.mark.parametrize("method", ["covariance", "monte_carlo"])
def test_per_cell_levels_correlate_adjacent_gates_as_the_filter(method):
    """Adjacent-gate voltage correlation of the 1.6 us pulse at 250 m gates, against theory.

    Uniform scene, ideal antenna; the sample correlation E[V_g V_{g+1}*] / E|V_g|^2 over
    12 beams x 110 gates x 64 pulses (standard error about 0.01) must be within 0.05 of the
    continuous filter's (0.22, computed here by quadrature); gates two apart are uncorrelated.
    The combined level draws gates independently (correlation 0, documented).
    """
    expected = adjacent_correlation_theory()
    assert expected == pytest.approx(0.22, abs=0.01)
    beams = np.arange(12)
    inputs = ideal_inputs(uniform_truth(n_gates=120), beams, rectangular())
    iq = weather(inputs, beams, method, drops_per_cell=64)["iq"][:, 5:-5, :, 0]
    iq = iq.astype(np.complex128)
    power = np.mean(np.abs(iq) ** 2)
    rho1 = np.mean(iq[:, 1:] * iq[:, :-1].conj()) / power
    rho2 = np.mean(iq[:, 2:] * iq[:, :-2].conj()) / power
    assert abs(rho1) == pytest.approx(expected, abs=0.05)
    assert abs(rho2) < 0.05


def test_combined_level_draws_gates_independently():
    beams = np.arange(12)
    inputs = ideal_inputs(uniform_truth(n_gates=120), beams, rectangular())
    iq = weather(inputs, beams, "combined")["iq"][:, 5:-5, :, 0].astype(np.complex128)
    rho1 = np.mean(iq[:, 1:] * iq[:, :-1].conj()) / np.mean(np.abs(iq) ** 2)
    assert abs(rho1) < 0.05


def core_truth(n_gates=90, core=(40, 43), core_dbz=60.0, background_dbz=0.0, **fields):
    truth = uniform_truth(n_gates=n_gates, DBZH=background_dbz, **fields)
    truth["DBZH"].values[:, core[0] : core[1]] = core_dbz
    return truth


@pytest.mark.parametrize("method", ["combined", "covariance"])
def test_range_sidelobes_of_a_core_carry_the_expected_power(method):
    """A 60 dBZ core in 0 dBZ, seen through a 10 us LFM: the power a random level puts on the
    gates its range sidelobes reach (their expected power is the core's sidelobes, 20-40 dB
    below it) equals the expected level's, on average over those gates (12 beams x 32
    pulses x 5 gates a side: relative standard error about 0.05; tolerance 0.15), and the
    gates beyond the reach see only the background.
    """
    fs = 7.2e6
    response = matched(lfm(3.6e6, 10e-6, fs), fs)
    beams = np.arange(12)
    truth = core_truth(WRADH=1.0)
    inputs = ideal_inputs(truth, beams, response, pulses=32)
    out = weather(inputs, beams, method)
    power = np.mean(np.abs(out["iq"][..., 0].astype(np.complex128)) ** 2, axis=2)
    expected = out["signal_power"][..., 0].astype(np.float64)
    pad = range_model(response, GATE, LAMBDA, 5.0).pad
    sides = np.r_[42 - pad : 38, 45 : 41 + pad]
    assert np.all(expected[:, sides] > 30 * expected[:, 10:20].mean())  # sidelobes dominate
    ratio = power[:, sides].mean(axis=0) / expected[:, sides].mean(axis=0)
    assert ratio.mean() == pytest.approx(1.0, abs=0.15)
    far = np.r_[5 : 40 - pad - 1, 43 + pad + 1 : 85]
    assert power[:, far].mean() / expected[:, far].mean() == pytest.approx(1.0, abs=0.1)


@pytest.mark.parametrize("method", ["combined", "covariance"])
def test_long_pulse_keeps_100_db_in_float32(method):
    """An 80 dBZ core beside -20 dBZ through a 10 us LFM, in float32: gates beyond the range
    response's reach come back with their own (100 dB weaker) power, those inside it with
    the core's sidelobes, both as expected (relative standard error ~0.03). The combined
    level sums powers along range (exact products), the per-cell level voltages (FFT).
    """
    fs = 7.2e6
    response = matched(lfm(3.6e6, 10e-6, fs), fs)
    beams = np.arange(10)
    truth = core_truth(core=(20, 24), core_dbz=80.0, background_dbz=-20.0)
    inputs = ideal_inputs(truth, beams, response, pulses=32)
    pad = range_model(response, GATE, LAMBDA, 5.0).pad
    out = weather(inputs, beams, method, precision="float32")
    assert np.isfinite(out["iq"]).all()
    power = np.abs(out["iq"][..., 0].astype(np.complex128)) ** 2
    expected = out["signal_power"][..., 0].astype(np.float64)
    far = slice(24 + pad + 1, 85)
    assert power[:, far].mean() / expected[:, far].mean() == pytest.approx(1.0, abs=0.1)
    near = slice(24, 24 + pad)
    assert power[:, near].mean() / expected[:, near].mean() == pytest.approx(1.0, abs=0.15)
    assert expected[:, near].min() > 1e3 * expected[:, far].mean()


@pytest.mark.parametrize("method", ["expected", "combined", "covariance", "monte_carlo"])
def test_long_pulse_draws_each_beam_the_same_whatever_the_chunk(method):
    fs = 7.2e6
    response = matched(lfm(3.6e6, 10e-6, fs), fs)
    beams = np.arange(3)
    inputs = ideal_inputs(core_truth(n_gates=40, core=(18, 20)), beams, response, pulses=8)
    whole = weather(inputs, beams, method, drops_per_cell=16)
    one = weather(ideal_inputs(inputs["truth"], np.array([2]), response, pulses=8), np.array([2]),
                  method, drops_per_cell=16)  # fmt: skip
    np.testing.assert_array_equal(one["iq"][0], whole["iq"][2])


def test_gates_inside_the_blind_range_are_zero():
    """A 20 us pulse is blind to 3 km: the channel puts nothing there, and gates just beyond
    see the cells inside it through the range response (they are not eclipsed)."""
    response = rectangular(width_s=20e-6)
    blind = float(response.attrs["blind_range_m"])
    assert blind == pytest.approx(2998, abs=1)
    beams = np.arange(2)
    truth = uniform_truth(n_gates=40, first_m=1000.0)
    out = weather(ideal_inputs(truth, beams, response, pulses=8), beams, "covariance")
    inside = truth["range"].values < blind
    assert inside.sum() == 8
    assert not out["iq"][:, inside].any() and not out["signal_power"][:, inside].any()
    assert not out["echo_correlations"][:, inside].any()
    assert out["iq"][:, ~inside].all() and (out["signal_power"][:, ~inside] > 0).all()


def test_blind_range_is_masked_and_never_scored_end_to_end():
    """The uniform graph run with a 20 us pulse from 1 km: no moment inside the blind range,
    none scored there, every gate beyond it estimated and scored."""
    overrides = {
        "tx.width_s": 20e-6,
        "scene.first_gate_m": 1000.0,
        "scene.gates": 40,
        "scan.azimuth_stop_deg": 4.0,
        "scan.pulses": 16,
    }
    graph = load(GRAPHS / "uniform_ideal.yaml", overrides)
    sweep = LocalExecutor(graph, RunOptions(seed=3)).run()
    rng = sweep["range"].values
    inside = rng < SPEED_OF_LIGHT * 20e-6 / 2
    assert inside.sum() == 8
    for name in ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"):
        assert np.isnan(sweep[name].values[:, inside]).all(), name
        assert np.isfinite(sweep[name].values[:, ~inside]).all(), name
    assert not sweep["scored"].values[:, inside].any()
    assert sweep["scored"].values[:, ~inside].all()


def test_response_that_is_not_the_filter_output_is_refused():
    response = rectangular()
    bad = response.copy(deep=True)
    bad["voltage"].values[:] = bad["voltage"].values[::-1] * 0.5
    with pytest.raises(ValueError, match="not the convolution"):
        range_model(bad, GATE, LAMBDA, 10.0)
