"""Spectrum width as the simulated radar sees it (``channel.weather`` ``width_model``).

What each test compares against:

* a radar file's widths: the truth radar's rotation broadening removed in quadrature,
  sigma_alpha = alpha lambda sqrt(ln 2) / (2 pi theta_1) (Doviak and Zrnic 1993, eq. 5.38),
  computed here by hand from the defaults (11.4 deg/s, 0.95 deg, 2.8 GHz), and reported
  zeros raised to the 0.25 m/s floor first; a synthetic scene's widths are left intrinsic;
* a uniform field of intrinsic width 1 m/s seen by a rotating dish and by the planar array
  (electronically stepped): the width measured on the I/Q autocorrelation at lag 8 (pooled
  over 2,000 gates) is sqrt(1 + sigma_scan^2) for the dish (scan rate 2 deg per 32 pulses of
  1 ms, 1-deg beam: sigma_scan = 0.887 m/s) and 1 m/s for the array, within 10 %;
  ``width_model: truth`` gives the dish the truth's width;
* the shear across the beam against Doviak and Zrnic's sigma_s (see its test);
* (slow) the generic radar's DBZH at 4,096 pulses against its own expected level: the
  estimator noise averages down below 0.2 dB once width-0 gates are no pure tones.
"""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.truth.nexrad import truth_dataset
from pasim_blocks.weather.channel import WeatherChannel
from pasim_blocks.weather.width import WidthModel, radar_widths

from pasim_graph import Chunk
from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graph import load

from ..conftest import GRAPHS

WAVELENGTH_M = 299_792_458.0 / 2.8e9


def scan_modulation(rate_deg_s: float, wavelength_m: float, beamwidth_deg: float) -> float:
    return (
        np.deg2rad(rate_deg_s)
        * wavelength_m
        * np.sqrt(np.log(2))
        / (2 * np.pi * np.deg2rad(beamwidth_deg))
    )


def small_truth(instrument: str):
    width = np.array([[0.0, 0.5, 2.0, np.nan]])
    fields = {"DBZH": np.full(width.shape, 30.0), "WRADH": width}
    return truth_dataset(
        fields, np.array([10.0]), np.arange(4) * 250.0 + 1e4, instrument_name=instrument
    )


def test_radar_truth_loses_its_rotation_broadening():
    params = WeatherChannel(name="weather").widths()  # the block's defaults
    assert params == WidthModel()
    sigma_nexrad = scan_modulation(11.4, WAVELENGTH_M, 0.95)
    assert abs(sigma_nexrad - 0.170) < 0.001
    got = radar_widths(small_truth("KLBB"), params, 0.0)["WRADH"].values[0]
    want = np.sqrt(np.maximum([0.25, 0.5, 2.0], 0.25) ** 2 - sigma_nexrad**2)
    np.testing.assert_allclose(got[:3], want, rtol=1e-6)
    assert np.isnan(got[3])
    # This radar's broadening adds in quadrature.
    wider = radar_widths(small_truth("KLBB"), params, 0.5)["WRADH"].values[0, :3]
    np.testing.assert_allclose(wider, np.hypot(want, 0.5), rtol=1e-6)
    # A synthetic scene is intrinsic already; width_model truth keeps every width as given.
    scene = radar_widths(small_truth("synthetic"), params, 0.0)["WRADH"].values[0, :3]
    np.testing.assert_allclose(scene, [0.0, 0.5, 2.0])
    as_given = radar_widths(small_truth("KLBB"), WidthModel("truth"), 0.5)
    np.testing.assert_allclose(as_given["WRADH"].values[0, :3], [0.0, 0.5, 2.0])


def lag_width(iq: np.ndarray, lag: int, prt_s: float) -> float:
    """Width of a Gaussian spectrum from the pooled autocorrelation at ``lag`` over lag 0."""
    r = np.mean(np.conj(iq[..., :-lag]) * iq[..., lag:])
    r0 = np.mean(np.abs(iq) ** 2)
    return float(WAVELENGTH_M / (np.pi * lag * prt_s) * np.sqrt(-np.log(abs(r) / r0) / 8))


@pytest.mark.parametrize(
    ("graph", "model", "sigma_scan"),
    [
        ("uniform_ideal.yaml", "physical", scan_modulation(2.0 / 0.032, WAVELENGTH_M, 1.0)),
        ("uniform_ideal.yaml", "truth", 0.0),
        ("uniform_planar.yaml", "physical", 0.0),
    ],
)
def test_uniform_width_is_intrinsic_plus_the_scan_modulation(graph, model, sigma_scan):
    overrides = {
        "scene.spectrum_width_ms": 1.0,
        "scan.beam_spacing_deg": 2.0,
        "scan.pulses": 32,
        "receiver.snr_db": 40.0,
        "weather.width_model": model,
    }
    sweep = LocalExecutor(load(GRAPHS / graph, overrides), RunOptions(seed=1, save_iq=True)).run()
    measured = lag_width(sweep["IQ_H"].values, 8, 1e-3)
    assert abs(measured / np.hypot(1.0, sigma_scan) - 1) < 0.1


def dbzh_against_expected(model: str, sector: tuple[float, float], pulses: int) -> np.ndarray:
    """DBZH of the combined level less the expected level's, on the scored gates."""
    overrides = {
        "scan.azimuth_start_deg": sector[0],
        "scan.azimuth_stop_deg": sector[1],
        "scan.pulses": pulses,
        "weather.width_model": model,
    }
    options = RunOptions(seed=0, fields=("DBZH",), chunk_beams=1)
    graph = GRAPHS / "generic_radar.yaml"
    drawn = LocalExecutor(load(graph, {**overrides, "weather.method": "combined"}), options).run()
    exact = LocalExecutor(load(graph, {**overrides, "weather.method": "expected"}), options).run()
    scored = np.isfinite(drawn["error_DBZH"].values) & np.isfinite(exact["DBZH"].values)
    return (drawn["DBZH"].values - exact["DBZH"].values)[scored]


@pytest.mark.slow  # about a minute on 2 cores
def test_reflectivity_noise_averages_down_at_4096_pulses():
    """The generic radar at 4,096 pulses over 240:250 of the bundled sweep: DBZH against its
    own expected level within 0.2 dB (std over the scored gates; the estimator noise of
    4,096 pulses). With the truth's widths as given, its width-0 gates are pure tones whose
    power never averages down: 0.39 dB. (Whole 240:330 sector: 0.132 against 0.384 dB.)"""
    assert np.std(dbzh_against_expected("physical", (240.0, 250.0), 4096)) < 0.2
    assert np.std(dbzh_against_expected("truth", (240.0, 250.0), 4096)) > 0.3


def test_shear_across_the_beam_comes_from_the_truth_cells():
    """The simulated radar's shear broadening is the truth's velocity gradient seen through
    its beam: a truth with intrinsic width 0.5 m/s and an azimuthal shear of 1.5 m/s per deg
    (uniform in range), seen by the 1-deg pencil beam held still (``antenna_motion``
    electronic) at the expected level, returns sqrt(0.5^2 + sigma_s^2) within 10 %, with
    sigma_s = k r sigma_theta (Doviak and Zrnic 1993, eq. 5.43 for a Gaussian two-way
    pattern, sigma_theta = theta_1 / (4 sqrt(ln 2)) = 0.30 deg) widened by the truth's
    0.5-deg radials (velocity constant across each: Delta^2 / 12 more angular variance).
    Measured 0.698 m/s against 0.707 m/s (0.673 m/s without the grouping term); without the
    shear it would be 0.5 m/s, 29 % low."""
    from pasim_blocks.angles import circular_difference
    from pasim_blocks.processing.pulse_pair import moments_from_correlations
    from pasim_blocks.signals import CORRELATION_PRODUCTS

    from .test_block_weather import chain_inputs, uniform_truth

    beams = np.arange(4)
    truth = uniform_truth(n_gates=20, WRADH=0.5)
    az = truth["azimuth"].values
    inputs = chain_inputs(truth, beams)
    k = 1.5
    widths = []
    for beam in beams:
        centre = float(inputs["beams"]["azimuth"].values[beam])
        offset = np.clip(circular_difference(az, np.asarray(centre), 360.0), -4.0, 4.0)
        sheared = truth.copy()
        v = np.repeat((k * offset)[:, None], truth.sizes["gate"], 1)
        sheared["VRADH"] = (("radial", "gate"), v.astype(np.float32))
        block = WeatherChannel(name="weather", method="expected", antenna_motion="electronic")
        one = {
            **inputs,
            "truth": sheared,
            "beams": inputs["beams"].isel(beam=[beam]),
            "pattern": inputs["pattern"].isel(beam=[beam]),
        }
        out = block.process(one, Chunk(beams=np.array([beam]), block_name="weather"))
        c = out["echo_correlations"][0, 5:-5]
        corr = {name: c[..., i] for i, name in enumerate(CORRELATION_PRODUCTS)}
        prt = float(inputs["beams"]["prt"].values[0])
        widths.append(moments_from_correlations(corr, 0.0, 0.0, prt, WAVELENGTH_M)["WRADH"])
    sigma_theta = 1.0 / (4 * np.sqrt(np.log(2)))
    sigma_s = k * np.sqrt(sigma_theta**2 + 0.5**2 / 12)
    np.testing.assert_allclose(np.concatenate(widths), np.hypot(0.5, sigma_s), rtol=0.1)
