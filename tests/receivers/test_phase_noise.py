"""Oscillator phase noise (``receiver.phase_noise``, ``blocks/receivers/phase_noise.py``).

References: the coherency a flat -100 dBc/Hz profile leaves a zero-velocity point target is
compared with the closed-form integral of the profile in ``tests/reference/phase_noise.py``
(independent of the block's FFT synthesis); the synthesised phase's variance with 2 x the
integral of L; chunking against the per-beam streams' definition (identical numbers).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.receivers.phase_noise import PhaseNoise, parse_profile, synthesise

from pasim_graph import Chunk

from ..reference.phase_noise import flat_covariance, residual_fraction

C = 299_792_458.0
PRT = 1e-3
PULSES = 64
BANDWIDTH = 625e3  # the matched filter's noise bandwidth of a 1.6 us pulse
RANGES = np.array([75.0, 300.0, 3e3, 30e3, 140e3])


def calibration(ranges=RANGES, prt=PRT):
    return xr.Dataset({"range": ("range", ranges)}, attrs={"prt_s": prt})


def response(bandwidth=BANDWIDTH):
    return xr.Dataset(attrs={"noise_bandwidth_hz": bandwidth})


def point_targets(beams: int) -> np.ndarray:
    return np.ones((beams, RANGES.size, PULSES, 2), np.complex64)


def run(block, iq, beams, seed=3):
    return block.process(
        {"iq_in": iq, "calibration": calibration(), "range_response": response()},
        Chunk(beams=beams, seed=seed, block_name="pn"),
    )["iq"]


def test_flat_profile_limits_coherency_as_the_integral_predicts():
    """-100 dBc/Hz flat over the receiver's band (+-312.5 kHz): the power a zero-velocity point
    target leaves after removing its dwell mean, against the closed-form integral of the
    profile, within 2 dB at every range (300 beams); near targets decorrelate less."""
    beams = 300
    block = PhaseNoise(name="pn", profile_dbc_hz="1e2:-100, 1e8:-100")
    x = run(block, point_targets(beams), np.arange(beams))
    h = x[..., 0].astype(np.complex128)
    resid = np.mean(np.abs(h - h.mean(axis=2, keepdims=True)) ** 2, axis=(0, 2))
    measured_db = 10 * np.log10(resid)
    predicted_db = np.array(
        [
            10
            * np.log10(
                residual_fraction(flat_covariance(-100, BANDWIDTH / 2, 2 * r / C, PRT, PULSES))
            )
            for r in RANGES
        ]
    )
    np.testing.assert_allclose(measured_db, predicted_db, atol=2.0)
    assert predicted_db[0] < predicted_db[-1] - 3  # 75 m against 140 km
    assert measured_db[0] < measured_db[-1] - 3
    # H and V share the oscillator: the same phase on both channels.
    np.testing.assert_array_equal(x[..., 0], x[..., 1])


def test_synthesised_phase_variance_is_twice_the_profile_integral():
    """A profile of -90 dBc/Hz from 1 kHz to 100 kHz (flat below 1 kHz down to the grid's
    resolution): the phase's variance against 2 x int L df, within 5 %."""
    offsets, levels = parse_profile("1e3:-90, 1e5:-90")
    rate, n = 1.6e6, 1 << 20
    phi = synthesise(np.random.default_rng(0), n, rate, offsets, levels)
    expected = 2 * 1e-9 * (1e5 - rate / n)
    assert np.var(phi) == pytest.approx(expected, rel=0.05)


def test_same_numbers_whatever_the_chunking():
    block = PhaseNoise(name="pn", profile_dbc_hz="1e3:-80, 1e5:-110")
    iq = point_targets(5)
    whole = run(block, iq, np.arange(5))
    parts = [run(block, iq[s], np.arange(5)[s]) for s in (slice(0, 2), slice(2, 5))]
    np.testing.assert_array_equal(whole, np.concatenate(parts))
    assert whole.dtype == np.complex64


@pytest.mark.parametrize(
    "text", ["1e3:-100, 1e2:-90", "abc", "1e3:-100:3", "-5:-100", "1e3:10", ""]
)
def test_bad_profile_is_a_configuration_error(text):
    problems = PhaseNoise.check_config({"profile_dbc_hz": text}, set())
    assert problems and problems[0][0] == "parameter 'profile_dbc_hz'"


def test_expected_level_and_huge_grid_are_refused():
    block = PhaseNoise(name="pn")
    empty = np.zeros((1, RANGES.size, 0, 2), np.complex64)
    with pytest.raises(ValueError, match="no pulses"):
        block.process(
            {"iq_in": empty, "calibration": calibration()},
            Chunk(beams=np.arange(1), expected=True),
        )
    # Without the receive filter the default profile reaches 10 MHz: too fine a grid.
    with pytest.raises(ValueError, match="range_response"):
        PhaseNoise(name="pn", profile_dbc_hz="1e3:-100, 1e9:-100").process(
            {"iq_in": point_targets(1), "calibration": calibration()}, Chunk(beams=np.arange(1))
        )
