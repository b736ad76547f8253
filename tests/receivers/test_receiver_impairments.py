"""Receiver impairments (ADC, gain compression, I/Q imbalance) against theory.

Each test names its reference: quantisation noise step^2 / 12 per rail (Widrow), the clipped
power of a complex Gaussian by numerical integration of the normal density, the Rapp 1 dB
point by its definition, the textbook image rejection ratio.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.receivers.adc import ADC, quantise
from pasim_blocks.receivers.gain_compression import ReceiverCompression
from pasim_blocks.receivers.iq_imbalance import IQImbalance, image_rejection_db
from pasim_blocks.receivers.receiver import Receiver
from scipy import integrate, stats

from pasim_graph import Chunk, load
from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graphfile import BlockSpec, ConnectionSpec, Endpoint, dumps, read

from ..conftest import GRAPHS


def gaussian_iq(shape, power_w, seed=1):
    rng = np.random.default_rng(seed)
    s = np.sqrt(power_w / 2)
    return (s * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape))).astype(np.complex64)


def full_scale_dbm(rail_sqrt_w: float) -> float:
    return 10 * np.log10(rail_sqrt_w**2) + 30


# ---------------------------------------------------------------------------------- ADC alone


def test_quantiser_levels_and_rails():
    step, bits = 0.1, 3
    x = np.array([-10.0, -0.4, -0.05, 0.0, 0.05, 0.39, 0.41, 10.0])
    q, clipped = quantise(x, step, bits)
    # 8 mid-rise levels (k + 1/2) step, k = -4..3; rails at +-0.4.
    assert np.allclose(q, [-0.35, -0.35, -0.05, 0.05, 0.05, 0.35, 0.35, 0.35])
    assert clipped.tolist() == [True, False, False, False, False, False, True, True]
    assert np.all(np.abs(q - x)[~clipped] <= step / 2 + 1e-12)


def test_adc_is_deterministic_per_sample_and_reports_clipping():
    adc = ADC(name="adc", bits=8, full_scale_dbm=-30.0, gain_db=0.0)
    x = gaussian_iq((5, 40, 16, 2), 1e-6)  # -30 dBm: the rails clip the peaks
    whole = adc.process({"iq_in": x}, Chunk(beams=np.arange(5)))
    parts = [
        adc.process({"iq_in": x[s]}, Chunk(beams=np.arange(5)[s]))
        for s in (slice(0, 2), slice(2, 5))
    ]
    assert np.array_equal(whole["iq"], np.concatenate([p["iq"] for p in parts]))
    assert whole["iq"].dtype == np.complex64 and whole["iq"].shape == x.shape
    rail = adc.rail()
    over = (np.abs(x.real) >= rail) | (np.abs(x.imag) >= rail)
    counts = whole["clipping"]["ADC_CLIPPED"].values
    assert np.array_equal(counts, over.sum(axis=(2, 3)))
    assert whole["clipping"].attrs["clipped_samples"] == int(over.sum()) > 0
    assert whole["clipping"].attrs["clipped_gates"] == int((counts > 0).sum())
    assert np.abs(whole["iq"].real).max() < rail and "noise_power" not in whole


def test_adc_gain_refers_full_scale_to_the_receiver_input():
    a = ADC(name="adc", bits=10, full_scale_dbm=0.0, gain_db=60.0)
    b = ADC(name="adc", bits=10, full_scale_dbm=-60.0, gain_db=0.0)
    assert a.rail() == pytest.approx(b.rail()) == pytest.approx(np.sqrt(1e-9))


def test_adc_needs_pulses():
    adc = ADC(name="adc")
    with pytest.raises(ValueError, match="no pulses"):
        adc.process(
            {"iq_in": np.zeros((1, 4, 0, 2), np.complex64)},
            Chunk(beams=np.arange(1), expected=True),
        )


def test_12_bit_adc_raises_the_noise_floor_by_step_squared_over_12_per_rail():
    """Theory: uniform quantisation noise step^2/12 on each of I and Q (Widrow; holds when the
    input spans several steps). The thermal noise comes from receiver.basic (k T0 F B, its own
    streams), the step equals its rms per rail, so the floor rises by 10 log10(1 + 1/12)."""
    bandwidth = 1.0e6
    rx = Receiver(name="receiver", noise_figure_db=3.0)
    response = xr.Dataset(attrs={"noise_bandwidth_hz": bandwidth})
    echo = np.zeros((4, 2000, 64, 2), np.complex64)
    chunk = Chunk(beams=np.arange(4), seed=5, block_name="receiver", options={"fields": None})
    out = rx.process({"iq_in": echo, "range_response": response}, chunk)
    noise = out["noise_power"]
    step = float(np.sqrt(noise[0, 0, 0] / 2))  # the rms of one rail
    rail = step * 2**11
    adc = ADC(name="adc", bits=12, full_scale_dbm=full_scale_dbm(rail), gain_db=0.0)
    assert adc.step() == pytest.approx(step, rel=1e-9)
    res = adc.process({"iq_in": out["iq"], "noise_power_in": noise}, Chunk(beams=np.arange(4)))
    before = np.mean(np.abs(out["iq"].astype(np.complex128)) ** 2)
    after = np.mean(np.abs(res["iq"].astype(np.complex128)) ** 2)
    measured_db = 10 * np.log10(after / before)
    theory_db = 10 * np.log10((noise[0, 0, 0] + 2 * step**2 / 12) / noise[0, 0, 0])
    print(f"noise floor rise: measured {measured_db:.3f} dB, theory {theory_db:.3f} dB")
    assert measured_db == pytest.approx(theory_db, abs=0.2)
    assert np.allclose(res["noise_power"], noise + 2 * step**2 / 12)
    assert res["clipping"].attrs["clipped_samples"] == 0


# ------------------------------------------------------------------------------- compression


def rapp_power_by_integration(power_w, a_sat, p):
    """E|A(r)|^2 for a circular complex Gaussian of power P: r is Rayleigh with E r^2 = P."""

    def integrand(r):
        out = r / (1 + (r / a_sat) ** (2 * p)) ** (1 / (2 * p))
        return out**2 * (2 * r / power_w) * np.exp(-(r**2) / power_w)

    return integrate.quad(integrand, 0, np.inf, limit=200)[0]


def test_compression_1db_point_and_gaussian_power():
    """The 1 dB point by definition (a tone at P1dB comes out 1 dB low, small signals pass at
    unit gain); the mean power of compressed Gaussian noise against numerical integration of
    the Rapp AM/AM over the Rayleigh amplitude density."""
    block = ReceiverCompression(name="lna", p1db_dbm=-30.0, smoothness=2.0)
    p1 = 10 ** ((-30.0 - 30) / 10)
    tone = np.full((1, 1, 4, 2), np.sqrt(p1), np.complex64) * np.exp(1j * 0.3).astype(np.complex64)
    out = block.process({"iq_in": tone}, Chunk(beams=np.arange(1)))["iq"]
    assert 10 * np.log10(np.abs(out[0, 0, 0, 0]) ** 2 / p1) == pytest.approx(-1.0, abs=1e-4)
    assert np.angle(out[0, 0, 0, 0]) == pytest.approx(0.3, abs=1e-5)  # no AM/PM
    small = tone * np.float32(1e-3)
    assert np.allclose(
        block.process({"iq_in": small}, Chunk(beams=np.arange(1)))["iq"], small, rtol=1e-5
    )
    from pasim_blocks.receivers.gain_compression import saturation_from_p1db

    a_sat = saturation_from_p1db(p1, 2.0)
    x = gaussian_iq((2, 500, 200, 2), p1)
    y = block.process({"iq_in": x}, Chunk(beams=np.arange(2)))["iq"]
    measured = np.mean(np.abs(y.astype(np.complex128)) ** 2)
    expected = rapp_power_by_integration(p1, a_sat, 2.0)
    assert 10 * np.log10(measured / expected) == pytest.approx(0.0, abs=0.02)


# ------------------------------------------------------------------------------ I/Q imbalance


def test_iq_imbalance_image_rejection_matches_the_textbook_formula():
    """Image rejection (1 + 2 g cos phi + g^2) / (1 - 2 g cos phi + g^2) for 0.5 dB, 3 deg,
    measured as the power at +f over the power at -f of a slow-time tone."""
    block = IQImbalance(name="iq", gain_imbalance_db=0.5, phase_imbalance_deg=3.0)
    n = 256
    m = np.arange(n)
    tone = np.exp(2j * np.pi * 19 * m / n).astype(np.complex64)
    x = np.broadcast_to(tone[None, None, :, None], (1, 3, n, 2)).copy()
    y = block.process({"iq_in": x}, Chunk(beams=np.arange(1)))["iq"]
    spectrum = np.abs(np.fft.fft(y[0, 0, :, 0].astype(np.complex128))) ** 2
    measured = 10 * np.log10(spectrum[19] / spectrum[n - 19])
    g = 10 ** (0.5 / 20)
    c = 2 * g * np.cos(np.deg2rad(3.0))
    textbook = 10 * np.log10((1 + c + g * g) / (1 - c + g * g))
    print(f"image rejection: measured {measured:.3f} dB, textbook {textbook:.3f} dB")
    assert measured == pytest.approx(textbook, abs=0.5)
    assert image_rejection_db(0.5, 3.0) == pytest.approx(textbook, abs=1e-9)
    # No imbalance: no image, and the block is the identity.
    same = IQImbalance(name="iq").process({"iq_in": x}, Chunk(beams=np.arange(1)))["iq"]
    assert np.allclose(same, x)


# ------------------------------------------------------------- the ADC on the bundled volume


def adc_graph(tmp_path, sector=(280.0, 285.0), pulses=64):
    """generic_radar.yaml with an ADC alone between receiver and processor."""
    spec = read(GRAPHS / "generic_radar.yaml")
    spec.blocks["adc"] = BlockSpec("receiver.adc", {"bits": 16, "gain_db": 0.0})
    moved = {
        "receiver.iq -> ppp.iq",
        "receiver.noise_power -> ppp.noise_power",
        "receiver.noise_power -> scorer.noise_power",
    }
    spec.connections = [c for c in spec.connections if str(c) not in moved]

    def wire(a, b):
        return ConnectionSpec(Endpoint(*a.split(".")), Endpoint(*b.split(".")))

    spec.connections += [
        wire("receiver.iq", "adc.iq_in"),
        wire("receiver.noise_power", "adc.noise_power_in"),
        wire("adc.iq", "ppp.iq"),
        wire("adc.noise_power", "ppp.noise_power"),
        wire("adc.noise_power", "scorer.noise_power"),
    ]
    path = tmp_path / "adc.yaml"
    path.write_text(dumps(spec))
    scan = {
        "scan.azimuth_start_deg": sector[0],
        "scan.azimuth_stop_deg": sector[1],
        "scan.pulses": pulses,
    }
    return path, scan


@pytest.fixture(scope="module")
def sector_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("adc")
    path, scan = adc_graph(tmp)
    ideal = LocalExecutor(load(GRAPHS / "generic_radar.yaml", scan), RunOptions(seed=2)).run()
    # The strongest expected echo of the sector (H), from the ideal run's SNR and its noise.
    ex = LocalExecutor(load(GRAPHS / "generic_radar.yaml", scan), RunOptions(seed=2))
    ex.load()
    static = ex.run_static()
    bandwidth = static[("mf", "range_response")].attrs["noise_bandwidth_hz"]
    noise_w = 1.380649e-23 * 290.0 * 10 ** (2.7 / 10) * bandwidth
    signal_w = noise_w * 10 ** (ideal["SNRH"].values.astype(np.float64) / 10)
    strongest_dbm = 10 * np.log10(np.nanmax(signal_w)) + 30

    def run(fs_dbm, bits=16):
        overrides = {**scan, "adc.full_scale_dbm": fs_dbm, "adc.bits": bits}
        return LocalExecutor(load(path, overrides), RunOptions(seed=2)).run()

    return {
        "ideal": ideal,
        "signal_w": signal_w,
        "noise_w": noise_w,
        "strongest_dbm": strongest_dbm,
        "run": run,
    }


def test_16_bit_adc_10_db_above_the_strongest_echo_leaves_dbzh_std(sector_runs):
    """Theory: with the rails 10 dB above the strongest expected echo almost nothing clips and
    16-bit quantisation noise sits far below the thermal floor, so the DBZH error std against
    truth equals the ideal receiver's (same seed, same draws) within 0.05 dB."""
    ideal = sector_runs["ideal"]
    adc = sector_runs["run"](sector_runs["strongest_dbm"] + 10.0)
    scored = ideal["scored"].values.astype(bool)
    std_ideal = np.nanstd(ideal["error_DBZH"].values[scored])
    std_adc = np.nanstd(adc["error_DBZH"].values[scored])
    print(f"DBZH std ideal {std_ideal:.4f} dB, 16-bit ADC {std_adc:.4f} dB")
    assert abs(std_adc - std_ideal) < 0.05
    assert adc["ADC_CLIPPED"].values.sum() < 1e-4 * adc["ADC_CLIPPED"].size * 128


def clipped_power(power_w, rail):
    """E[clip(I)^2 + clip(Q)^2] for a circular complex Gaussian of power P, each rail clipped at
    +-A, by numerical integration of the normal density (independent of the block's code)."""
    s = np.sqrt(power_w / 2)

    def one_rail():
        inside = integrate.quad(lambda x: x**2 * stats.norm.pdf(x, scale=s), -rail, rail)[0]
        return inside + rail**2 * 2 * stats.norm.sf(rail, scale=s)

    return 2 * one_rail()


def test_16_bit_adc_30_db_below_the_strongest_echo_clips_the_cores(sector_runs):
    """Full scale 30 dB below the strongest echo: the cores clip, and the DBZH change against
    the ideal receiver (same draws) matches the clipped complex Gaussian's power loss computed
    by numerical integration, gate by gate, within 0.5 dB on average over the clipped cores."""
    ideal = sector_runs["ideal"]
    fs_dbm = sector_runs["strongest_dbm"] - 30.0
    adc = sector_runs["run"](fs_dbm)
    rail = np.sqrt(10 ** ((fs_dbm - 30) / 10))
    signal = sector_runs["signal_w"]
    noise = sector_runs["noise_w"]
    cores = (signal > 10 ** ((fs_dbm - 30) / 10)) & np.isfinite(ideal["DBZH"].values)
    cores &= np.isfinite(adc["DBZH"].values)
    assert cores.sum() > 50
    clipped = adc["ADC_CLIPPED"].values
    assert (clipped[cores] > 0).all()  # every core gate is reported clipped
    # The quantisation noise (step^2/6) is in the output and in the noise the ADC hands on,
    # so it cancels in the noise-subtracted power: what is left is the clipping of echo + noise.
    theory = np.array(
        [10 * np.log10((clipped_power(s + noise, rail) - noise) / s) for s in signal[cores]]
    )
    measured = adc["DBZH"].values[cores] - ideal["DBZH"].values[cores]
    print(
        f"{cores.sum()} core gates: DBZH change measured {measured.mean():.2f} dB, "
        f"clipped-Gaussian theory {theory.mean():.2f} dB"
    )
    assert measured.mean() == pytest.approx(theory.mean(), abs=0.5)
    assert theory.mean() < -3.0  # a real clipping loss, not a no-op
