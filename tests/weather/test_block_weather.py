"""The weather channel on a uniform synthetic field, against the radar equation and eq. 13-18."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.antennas.pencil import PencilBeamAntenna
from pasim_blocks.processing.pulse_pair import pulse_pair
from pasim_blocks.receivers.filters import MatchedFilter
from pasim_blocks.scans.ppi import PPISector
from pasim_blocks.signals import SPEED_OF_LIGHT
from pasim_blocks.waveforms.pulses import RectangularPulse
from pasim_blocks.weather.channel import WeatherChannel

from pasim_graph import Chunk

FIELDS = {"DBZH": 30.0, "ZDR": 1.0, "RHOHV": 0.98, "PHIDP": 30.0, "VRADH": 5.0, "WRADH": 2.0}
NO_BEAMS = np.arange(0)


def uniform_truth(n_gates=120, first_m=20_000.0, **override):
    az = np.arange(720) * 0.5 + 0.25
    values = {**FIELDS, **override}
    shape = (az.size, n_gates)
    return xr.Dataset(
        {k: (("radial", "gate"), np.full(shape, v, np.float32)) for k, v in values.items()},
        coords={"azimuth": ("radial", az), "range": ("gate", first_m + 250.0 * np.arange(n_gates))},
        attrs={
            "radial_width_deg": 0.5,
            "gate_width_m": 250.0,
            "elevation_deg": 0.5,
            "time_coverage_start": "2016-06-01T15:00:25Z",
            "latitude": 33.0,
            "longitude": -101.0,
            "altitude": 1000.0,
        },
    )


def chain_inputs(truth, beams_idx, pulses=64):
    scan = PPISector(name="scan", azimuth_start_deg=100.0, azimuth_stop_deg=110.0, pulses=pulses)
    beams = scan.process({"truth": truth}, Chunk(beams=beams_idx))["beams"]
    antenna = PencilBeamAntenna(name="antenna", support_deg=4.0, grid_step_deg=0.05)
    pattern = antenna.process({"beams": beams}, Chunk(beams=beams_idx))["pattern"]
    pulse = RectangularPulse(name="tx").process({}, Chunk(beams=NO_BEAMS))["pulse"]
    response = MatchedFilter(name="mf").process(
        {"pulse": pulse, "reference": pulse}, Chunk(beams=NO_BEAMS)
    )["range_response"]
    return {"truth": truth, "beams": beams, "pattern": pattern, "range_response": response}


def run(truth, beams_idx, seed=1, pulses=64):
    inputs = chain_inputs(truth, beams_idx, pulses)
    out = WeatherChannel(name="weather").process(
        inputs, Chunk(beams=beams_idx, seed=seed, block_name="weather")
    )
    return inputs, out


@pytest.fixture(scope="module")
def uniform_run():
    return run(uniform_truth(), np.arange(10))


def test_expected_power_is_the_radar_equation(uniform_run):
    """A uniform 30 dBZ field comes back as 30 dBZ through the calibration (radar equation).

    Independent check of the constant: Pt G^2 lambda^2 pi^5 |K|^2 Z Omega R / ((4 pi)^3
    lambda^4 r^2) with Omega the two-way pattern integral and R the range-weighting integral;
    for a rectangular pulse and matched filter R = 2/3 * c tau / 2 (integral of a squared
    triangle).
    """
    inputs, out = uniform_run
    cal = out["calibration"]
    r = cal["range"].values
    p = out["signal_power"][:, 2:-2, 0].astype(np.float64)  # away from the field's edges
    dbz = 10 * np.log10(p) + 20 * np.log10(r[2:-2]) - cal["radar_constant_db"].values[0, 0]
    np.testing.assert_allclose(dbz, 30.0, atol=0.01)

    lam = SPEED_OF_LIGHT / 2.8e9
    omega = inputs["pattern"].attrs["two_way_solid_angle_sr_H"]
    range_integral = 2 / 3 * SPEED_OF_LIGHT * 1.6e-6 / 2
    const = (
        700e3
        * (10**4.55) ** 2
        * lam**2
        * np.pi**5
        * 0.93
        * 1e-18
        * omega
        * range_integral
        / ((4 * np.pi) ** 3 * lam**4)
    )
    assert cal["radar_constant_db"].values[0, 0] == pytest.approx(10 * np.log10(const), abs=0.02)
    # V has ZDR = 1 dB less power.
    ratio = out["signal_power"][:, 2:-2, 0] / out["signal_power"][:, 2:-2, 1]
    np.testing.assert_allclose(10 * np.log10(ratio), 1.0, atol=1e-4)


def test_drawn_series_have_the_truth_statistics(uniform_run):
    """Sample moments over ~1000 gates against the truth of eq. 13-18.

    Tolerances: each gate's lag-0 power from 64 correlated pulses has a relative std of about
    0.3, so the mean over 1,160 gates is good to ~1 %; velocity, ZDR, rho_hv and phi_DP are
    averaged likewise.
    """
    _, out = uniform_run
    iq = out["iq"][:, 2:-2]
    prt = 1 / 300
    lam = SPEED_OF_LIGHT / 2.8e9
    power = np.mean(np.abs(iq[..., 0]) ** 2)
    assert power / out["signal_power"][:, 2:-2, 0].mean() == pytest.approx(1.0, abs=0.03)
    est = pulse_pair(iq[..., 0], iq[..., 1], 0.0, 0.0, prt, lam)
    assert np.nanmean(est["VRADH"]) == pytest.approx(5.0, abs=0.1)
    assert np.nanmedian(est["ZDR"]) == pytest.approx(1.0, abs=0.05)
    assert np.nanmean(est["RHOHV"]) == pytest.approx(0.98, abs=0.005)
    assert np.nanmean(est["PHIDP"]) == pytest.approx(30.0, abs=0.5)
    # Width of the beam-weighted field: 2 m/s plus the (small) shear-free broadening of a
    # scanning-free pencil beam: none, so the estimate should sit near 2 m/s.
    assert np.nanmedian(est["WRADH"]) == pytest.approx(2.0, abs=0.15)


def test_each_beam_draws_the_same_numbers_whatever_the_chunk():
    truth = uniform_truth(n_gates=30)
    _, whole = run(truth, np.arange(4))
    for b in range(4):
        _, one = run(truth, np.array([b]))
        np.testing.assert_array_equal(one["iq"][0], whole["iq"][b])


def test_seed_changes_the_draw():
    truth = uniform_truth(n_gates=30)
    _, a = run(truth, np.arange(2), seed=1)
    _, b = run(truth, np.arange(2), seed=2)
    assert not np.array_equal(a["iq"], b["iq"])


def test_no_echo_gives_zero_signal():
    truth = uniform_truth(n_gates=20, DBZH=np.nan)
    _, out = run(truth, np.arange(2))
    assert not out["iq"].any() and not out["signal_power"].any()


def test_zero_width_and_rho_one_do_not_break():
    """Width 0 makes eq. 13 rank one and rho 1 makes V fully determined; both must draw."""
    truth = uniform_truth(n_gates=20, WRADH=0.0, RHOHV=1.0)
    _, out = run(truth, np.arange(2))
    assert np.isfinite(out["iq"]).all()
    iq = out["iq"][:, 2:-2]
    est = pulse_pair(iq[..., 0], iq[..., 1], 0.0, 0.0, 1 / 300, SPEED_OF_LIGHT / 2.8e9)
    assert np.nanmean(est["RHOHV"]) == pytest.approx(1.0, abs=1e-3)
