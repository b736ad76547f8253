"""Tests of the transmitter jitter block (``blocks/jitter.py``, ``transmitter.jitter``).

What each test compares against:

* the closed-form moments of the mean gain of N amplifiers with log-normal amplitude and
  Gaussian phase jitter (E G, E|G|^2, E[G_H* G_V]), against a direct Monte Carlo written
  here, and the block's own per-pulse gains against those moments;
* coherency: the lag-1 correlation coefficient of a jittered steady echo is |E G|^2 / E|G|^2,
  which tends to 1 as the number of independent transmitters grows (the jitter averages);
* the expected level: correlations scaled by those moments, so the processor sees the same
  coherency loss (a wider spectrum) without pulses;
* chunking: beams draw from their own streams.
"""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.signals import CORRELATION_PRODUCTS
from pasim_blocks.transmitters.jitter import TransmitterJitter, jitter_moments

from pasim_graph import Chunk


@pytest.mark.parametrize(("n", "c"), [(1, 0.0), (4, 0.5), (50, 1.0)])
def test_moments_against_monte_carlo(n: int, c: float) -> None:
    """1 dB and 10 deg rms jitter: E G, E|G|^2 and E[G_H* G_V] of the mean of N gains, from
    200 000 draws made here, within 4 standard errors."""
    rng = np.random.default_rng(7)
    draws = 200_000
    s, phi = np.log(10) / 20 * 1.0, np.radians(10.0)
    z = rng.standard_normal((4, draws, n))
    g_h = np.exp(s * z[0] + 1j * phi * z[1]).mean(axis=1)
    g_v = np.exp(
        s * (c * z[0] + np.sqrt(1 - c**2) * z[2]) + 1j * phi * (c * z[1] + np.sqrt(1 - c**2) * z[3])
    ).mean(axis=1)
    m = jitter_moments(1.0, 10.0, n, c)
    for value, sample in (
        (m["mean"], g_h),
        (m["power"], np.abs(g_h) ** 2),
        (m["cross"], np.conj(g_h) * g_v),
    ):
        err = np.std(sample) / np.sqrt(draws)
        assert abs(np.mean(sample) - value) < 4 * err + 1e-12


def steady_echo(beams=2, gates=3, pulses=4096, transmission="shv"):
    import xarray as xr

    iq = np.ones((beams, gates, pulses, 2), np.complex64)
    corr = np.ones((beams, gates, len(CORRELATION_PRODUCTS)), np.complex128)
    calibration = xr.Dataset(attrs={"transmission": transmission})
    return {"iq_in": iq, "echo_correlations_in": corr, "calibration": calibration}


@pytest.mark.parametrize("n", [1, 16, 256])
def test_coherency_loss_and_averaging(n: int) -> None:
    """A steady echo (all ones) through 0.5 dB / 5 deg jitter of N transmitters: the sample
    lag-1 correlation coefficient of each pulse train is |E G|^2 / E|G|^2 (within 0.003), and
    the excess 1 - rho_1 falls as 1/N."""
    block = TransmitterJitter(
        name="jitter", amplitude_jitter_db=0.5, phase_jitter_deg=5.0, transmitters=n
    )
    out = block.process(steady_echo(), Chunk(beams=np.arange(2), block_name="jitter"))
    g = out["iq"][0, 0, :, 0].astype(complex)
    rho1 = abs(np.mean(np.conj(g[:-1]) * g[1:])) / np.mean(np.abs(g) ** 2)
    m = jitter_moments(0.5, 5.0, n, 0.0)
    theory = abs(m["mean"]) ** 2 / m["power"].real
    assert rho1 == pytest.approx(theory, abs=0.003)
    one = jitter_moments(0.5, 5.0, 1, 0.0)
    excess_one = 1 - abs(one["mean"]) ** 2 / one["power"].real
    assert 1 - theory == pytest.approx(excess_one / n, rel=0.05)
    # all gates of a pulse get the same gain; H and V are independent amplifiers (c = 0)
    np.testing.assert_array_equal(out["iq"][0, 0], out["iq"][0, 2])
    assert not np.allclose(out["iq"][0, 0, :, 0], out["iq"][0, 0, :, 1])


def test_expected_level_scales_the_correlations() -> None:
    """No pulses: lag 0 by E|G|^2, every product of two different pulses (lags 1 and 2, the
    lag-1 H-V products of AHV) by |E G|^2, the lag-0 H-V term by E[G_H* G_V]; the I/Q cube
    passes through untouched."""
    block = TransmitterJitter(
        name="jitter", amplitude_jitter_db=1.0, phase_jitter_deg=20.0, transmitters=3
    )
    inputs = steady_echo(pulses=0)
    out = block.process(inputs, Chunk(beams=np.arange(2), block_name="jitter", expected=True))
    m = jitter_moments(1.0, 20.0, 3, 0.0)
    lagged = abs(m["mean"]) ** 2  # two different pulses
    expected = {"R0_H": m["power"], "R0_V": m["power"], "R0_HV": m["cross"]}
    expected |= dict.fromkeys(("R1_H", "R1_V", "R2_H", "R2_V", "R1_HV", "R1_VH"), lagged)
    for i, name in enumerate(CORRELATION_PRODUCTS):
        np.testing.assert_allclose(out["echo_correlations"][..., i], expected[name])
    assert out["iq"].shape[2] == 0
    assert expected["R1_H"] < 0.97 * expected["R0_H"].real  # coherency is lost


def test_alternate_transmission_has_one_transmitter_per_pulse() -> None:
    """AHV: pulse m is transmitted by the H amplifiers (m even) or the V ones (m odd), and both
    ports receive its echo, so both ports carry that pulse's gain: against the SHV gains drawn
    from the same stream, the H port's even pulses and the V port's odd ones are unchanged,
    the other ports take the transmitting port's gain."""
    block = TransmitterJitter(
        name="jitter", amplitude_jitter_db=0.5, phase_jitter_deg=5.0, transmitters=2
    )
    chunk = Chunk(beams=np.arange(2), seed=4, block_name="jitter")
    shv = block.process(steady_echo(pulses=64), chunk)["iq"]
    ahv = block.process(steady_echo(pulses=64, transmission="ahv"), chunk)["iq"]
    np.testing.assert_array_equal(ahv[..., 0], ahv[..., 1])
    np.testing.assert_array_equal(ahv[:, :, 0::2, 0], shv[:, :, 0::2, 0])
    np.testing.assert_array_equal(ahv[:, :, 1::2, 1], shv[:, :, 1::2, 1])
    assert not np.allclose(shv[..., 0], shv[..., 1])


def test_beams_draw_their_own_streams() -> None:
    """Beams 0-3 in one chunk or two give the same gains."""
    block = TransmitterJitter(name="jitter", transmitters=8)
    whole = block.process(
        steady_echo(beams=4, pulses=64), Chunk(beams=np.arange(4), seed=2, block_name="jitter")
    )["iq"]
    parts = [
        block.process(steady_echo(beams=2, pulses=64), Chunk(beams=b, seed=2, block_name="jitter"))[
            "iq"
        ]
        for b in (np.arange(2), np.arange(2, 4))
    ]
    np.testing.assert_array_equal(whole, np.concatenate(parts))


@pytest.mark.parametrize("transmission", ["shv", "ahv"])
def test_graph_with_jitter_runs_at_the_expected_level(transmission: str) -> None:
    """The block between the weather channel and the receiver and processor of the uniform
    scene's graph, in SHV and AHV: it validates and runs at the expected level, where the
    jitter shows as a wider spectrum (WRADH up) and DBZH moves by 10 log10 E|G|^2 exactly."""
    from pasim_graph.graphfile import BlockSpec, ConnectionSpec, Endpoint, read

    from ..conftest import GRAPHS

    spec = read(GRAPHS / "uniform_ideal.yaml")
    spec.blocks["jitter"] = BlockSpec(
        "transmitter.jitter", {"amplitude_jitter_db": 0.5, "phase_jitter_deg": 10.0}
    )
    moved = {"weather.iq -> receiver.iq_in", "weather.echo_correlations -> ppp.echo_correlations"}
    spec.connections = [c for c in spec.connections if str(c) not in moved]
    spec.connections += [
        ConnectionSpec(Endpoint("weather", "iq"), Endpoint("jitter", "iq_in")),
        ConnectionSpec(Endpoint("jitter", "iq"), Endpoint("receiver", "iq_in")),
        ConnectionSpec(
            Endpoint("weather", "echo_correlations"), Endpoint("jitter", "echo_correlations_in")
        ),
        ConnectionSpec(
            Endpoint("jitter", "echo_correlations"), Endpoint("ppp", "echo_correlations")
        ),
        ConnectionSpec(Endpoint("weather", "calibration"), Endpoint("jitter", "calibration")),
    ]
    from pasim_graph.executor import LocalExecutor
    from pasim_graph.graph import validate

    out = {}
    for name, graph_spec in (("jitter", spec), ("plain", read(GRAPHS / "uniform_ideal.yaml"))):
        graph = validate(
            graph_spec,
            {
                "scan.azimuth_stop_deg": 3.0,
                "weather.method": "expected",
                "weather.transmission": transmission,
            },
        )
        out[name] = LocalExecutor(graph).run()
    m = jitter_moments(0.5, 10.0, 1, 0.0)
    dbz = (out["jitter"]["DBZH"] - out["plain"]["DBZH"]).values
    assert np.isfinite(dbz).any()
    np.testing.assert_allclose(dbz[np.isfinite(dbz)], 10 * np.log10(m["power"].real), atol=1e-3)
    width = (out["jitter"]["WRADH"] - out["plain"]["WRADH"]).values
    assert np.nanmean(width) > 0.1
