"""A radar on a moving platform (scan.ppi's platform): beams steered in the array frame and
carried to the earth frame through the platform's attitude; the echo's radial velocity
relative to the moving radar and the platform-motion broadening; motion compensation in the
processor.

The references are independent: the velocity error against minus the platform velocity
projected on the beam (computed here from the beam's own azimuth and elevation), the
broadening against Doviak and Zrnic's closed form 0.3 v_perp theta_1 with the antenna's
declared beamwidth, the roll against a rotation about the nose axis written out by hand
(Rodrigues' formula).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from pasim_blocks.scans.platform import earth_pointing
from pasim_blocks.scans.ppi import PPISector

from pasim_graph import Chunk
from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graph import load

from ..conftest import GRAPHS

#: The aircraft: 150 m/s north, heading north, looking right (east) across the sector.
AIRBORNE = {
    "scan.platform": "airborne",
    "scan.azimuth_start_deg": 84.0,
    "scan.azimuth_stop_deg": 96.0,
    "scan.beam_spacing_deg": 2.0,
    "scan.elevation_deg": 0.0,
    "scene.velocity_ms": 0.0,
    "scene.gates": 40,
    "weather.method": "expected",
}


def run(**overrides):
    """uniform_ideal.yaml (ideal 1 deg beam, S band, T = 1 ms) at the expected level (each
    run once per session: the tests read, never change, what it returns)."""
    return _run(tuple(sorted(overrides.items())))


@functools.lru_cache(maxsize=8)
def _run(overrides):
    graph = load(GRAPHS / "uniform_ideal.yaml", {**AIRBORNE, **dict(overrides)})
    return LocalExecutor(graph, RunOptions(seed=3)).run()


def beam_means(sweep, name):
    return np.nanmean(sweep[name].values, axis=1)


def by_hand_radial(sweep, speed_ms=150.0):
    """The aircraft's velocity (north) on each beam, from the beam's earth azimuth and
    elevation."""
    az, el = np.deg2rad(sweep["azimuth"].values), np.deg2rad(sweep["elevation"].values)
    return speed_ms * np.cos(az) * np.cos(el)


def test_the_velocity_error_is_minus_the_platform_velocity_on_each_beam():
    """A uniform still scene from an aircraft at 150 m/s: without compensation each beam's
    mean velocity is minus the aircraft's velocity projected on it within 0.1 m/s; with the
    processor's motion compensation the bias is under 0.1 m/s."""
    sweep = run()
    vp = by_hand_radial(sweep)
    assert np.abs(vp).max() > 10.0  # the beams off broadside see the motion
    assert np.abs(beam_means(sweep, "VRADH") + vp).max() < 0.1
    assert np.allclose(sweep["platform_radial_velocity"].values, vp, atol=1e-9)
    fixed = run(**{"ppp.motion_compensation": True})
    assert np.abs(beam_means(fixed, "VRADH")).max() < 0.1


def test_the_motion_broadening_follows_the_closed_form():
    """The width added by the aircraft's motion across the beam, sqrt(W^2 - W_still^2), is
    0.3 v_perp theta_1 (Doviak and Zrnic) with the ideal antenna's 1 deg beam, within 10 %."""
    moving = beam_means(run(), "WRADH")
    still = beam_means(run(**{"scan.platform": "ground"}), "WRADH")
    sweep = run()
    az = np.deg2rad(sweep["azimuth"].values)
    v_perp = 150.0 * np.abs(np.sin(az))  # across a horizontal beam, in azimuth
    closed = v_perp * np.deg2rad(1.0) / (4 * np.sqrt(np.log(2)))
    added = np.sqrt(moving**2 - still**2)
    assert np.abs(added / closed - 1).max() < 0.10, (added, closed)


def rodrigues(v, axis, angle_deg):
    """v turned by angle about the unit axis (right-handed)."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    a = np.deg2rad(angle_deg)
    return v * np.cos(a) + np.cross(k, v) * np.sin(a) + k * np.dot(k, v) * (1 - np.cos(a))


@pytest.mark.parametrize("heading", [0.0, 37.0])
def test_a_10_deg_roll_moves_each_footprint_as_a_rotation_by_hand(heading):
    """A 10 deg roll (right side down) turns every beam about the nose axis: the earth
    azimuth and elevation of each beam of a sector steered in the array frame are those of
    the unrolled beam rotated by hand about the platform's nose, within 0.01 deg; beams
    across the right side go down by the roll, the nose beam does not move."""
    block = PPISector(
        name="scan",
        platform="airborne",
        platform_heading_deg=heading,
        platform_roll_deg=10.0,
        azimuth_start_deg=0.0,
        azimuth_stop_deg=180.0,
        beam_spacing_deg=15.0,
        elevation_deg=2.0,
    )
    beams = block.process({}, Chunk(beams=np.arange(block.beam_count())))["beams"]
    h = np.deg2rad(heading)
    nose = np.array([np.sin(h), np.cos(h), 0.0])  # east, north, up
    for a_arr, e_arr, az, el in zip(
        beams["array_azimuth"].values,
        beams["array_elevation"].values,
        beams["azimuth"].values,
        beams["elevation"].values,
        strict=True,
    ):
        a0, e0 = np.deg2rad(heading + a_arr), np.deg2rad(e_arr)
        level = np.array([np.sin(a0) * np.cos(e0), np.cos(a0) * np.cos(e0), np.sin(e0)])
        # Right side down: a right-handed turn about the nose in (east, north, up), east to down.
        rolled = rodrigues(level, nose, 10.0)
        want_az = np.rad2deg(np.arctan2(rolled[0], rolled[1])) % 360
        want_el = np.rad2deg(np.arcsin(rolled[2]))
        assert abs((az - want_az + 180) % 360 - 180) < 0.01
        assert abs(el - want_el) < 0.01
    right = np.argmin(np.abs(beams["array_azimuth"].values - 97.5))
    assert beams["elevation"].values[right] == pytest.approx(2.0 - 10.0, abs=0.1)


def test_no_platform_and_a_still_level_one_point_alike():
    """A still platform at heading, pitch and roll 0 points every beam where no platform
    does (the array frame is the earth frame)."""
    az, el = earth_pointing(np.array([0.0, 90.0, 271.0]), np.array([0.5, 3.0, -1.0]), 0, 0, 0)
    assert np.allclose(az, [0.0, 90.0, 271.0]) and np.allclose(el, [0.5, 3.0, -1.0])


def test_the_closed_form_matches_the_pattern_weighted_velocities_of_the_cells():
    """An independent route to the broadening: a still radar looking at a scene whose cells
    move as the aircraft's motion makes them look (each truth radial at -150 cos(az) m/s,
    0.05 deg radials) sums the cells' velocities through its ideal 1 deg pattern; its
    pulse-pair width and velocity, at the expected level, equal the moving platform's
    (closed-form broadening on a still scene, velocity shift on the beam) within 2 % and
    0.05 m/s."""
    from pasim_blocks.antennas.pencil import IdealAntenna
    from pasim_blocks.processing.pulse_pair import moments_from_correlations
    from pasim_blocks.receivers.filters import MatchedFilter
    from pasim_blocks.signals import CORRELATION_PRODUCTS
    from pasim_blocks.truth.scenes import UniformScene
    from pasim_blocks.waveforms.pulses import RectangularPulse
    from pasim_blocks.weather.channel import WeatherChannel

    none = np.arange(0)
    scene = UniformScene(
        name="scene", velocity_ms=0.0, spectrum_width_ms=1.0, gates=8, radial_width_deg=0.05
    )
    still = scene.process({}, Chunk(beams=none))["truth"]
    az = still["azimuth"].values
    sheared = still.copy()
    sheared["VRADH"] = (
        still["VRADH"].dims,
        np.broadcast_to(-150.0 * np.cos(np.deg2rad(az))[:, None], still["VRADH"].shape).astype(
            np.float32
        ),
        still["VRADH"].attrs,
    )
    pulse = RectangularPulse(name="tx", width_s=1e-6).process({}, Chunk(beams=none))["pulse"]
    response = MatchedFilter(name="mf").process(
        {"pulse": pulse, "reference": pulse}, Chunk(beams=none)
    )["range_response"]

    def moments(truth, platform):
        scan = PPISector(
            name="scan",
            azimuth_start_deg=84.0,
            azimuth_stop_deg=96.0,
            beam_spacing_deg=4.0,
            elevation_deg=0.0,
            prt_s=1e-3,
            platform=platform,
            align_to_truth=False,
        )
        idx = np.arange(scan.beam_count())
        beams = scan.process({"truth": truth}, Chunk(beams=idx))["beams"]
        pattern = IdealAntenna(name="a", beamwidth_deg=1.0).process(
            {"beams": beams}, Chunk(beams=idx)
        )["pattern"]
        out = WeatherChannel(name="w", method="expected", antenna_motion="electronic").process(
            {"truth": truth, "beams": beams, "pattern": pattern, "range_response": response},
            Chunk(beams=idx, seed=0, block_name="w"),
        )
        corr = {k: out["echo_correlations"][..., i] for i, k in enumerate(CORRELATION_PRODUCTS)}
        est = moments_from_correlations(
            {k: corr[k] for k in ("R0_H", "R1_H")}, 0.0, 0.0, 1e-3, 299_792_458.0 / 2.8e9
        )
        return np.nanmean(est["VRADH"], axis=1), np.nanmean(est["WRADH"], axis=1)

    v_cells, w_cells = moments(sheared, "ground")
    v_moving, w_moving = moments(still, "airborne")
    assert np.abs(v_cells - v_moving).max() < 0.05
    assert np.abs(w_cells / w_moving - 1).max() < 0.02, (w_cells, w_moving)


@pytest.mark.slow
def test_the_velocity_error_with_random_draws():
    """The same at the covariance level (64 pulses, 100 gates, seed 3): each beam's mean
    velocity is minus the platform's within 0.1 m/s (the estimates' own scatter included),
    and motion compensation takes exactly v_p off the same draws (within 1 mm/s)."""
    more = {"weather.method": "covariance", "scene.gates": 100}
    raw, fixed = run(**more), run(**more, **{"ppp.motion_compensation": True})
    vp = by_hand_radial(raw)
    assert np.abs(beam_means(raw, "VRADH") + vp).max() < 0.1
    assert np.abs(beam_means(fixed, "VRADH") - beam_means(raw, "VRADH") - vp).max() < 1e-3


def test_rates_acceleration_and_presets_over_the_scan():
    """Each dwell is turned with the attitude at its middle and carries the velocity then: a
    ship (8 m/s along its heading) turning at 2 deg/s and accelerating 0.5 m/s^2 east; the
    dwell's middle is (beam + 1/2) x pulses x PRT after the start (by hand)."""
    block = PPISector(
        name="scan",
        platform="ship",
        platform_heading_deg=90.0,
        platform_heading_rate_deg_s=2.0,
        platform_acceleration_east_ms2=0.5,
        azimuth_start_deg=0.0,
        azimuth_stop_deg=40.0,
        beam_spacing_deg=10.0,
        elevation_deg=0.0,
        pulses=100,
        prt_s=0.01,
    )
    idx = np.arange(block.beam_count())
    beams = block.process({}, Chunk(beams=idx))["beams"]
    mid = (idx + 0.5) * 100 * 0.01
    heading = 90.0 + 2.0 * mid
    assert np.allclose(beams["heading"].values, heading)
    assert np.allclose(beams["azimuth"].values, (heading + beams["array_azimuth"].values) % 360)
    assert np.allclose(beams["eastward_velocity"].values, 8.0 + 0.5 * mid)
    assert np.allclose(beams["northward_velocity"].values, 0.0, atol=1e-12)
    u_east = np.sin(np.deg2rad(beams["azimuth"].values))
    assert np.allclose(beams["platform_radial_velocity"].values, (8.0 + 0.5 * mid) * u_east)
    assert str(beams["platform_type"].values) == "ship"


def test_an_array_on_a_platform_steers_in_its_own_frame():
    """A planar array whose face looks left (270 deg from the nose) on an aircraft heading
    320 deg: its pattern for a beam steered 265 deg from the nose is the pattern a still array
    facing 270 deg forms for a beam at 265 deg (same numbers), though the beam points at 225
    deg on the earth."""
    from pasim_blocks.antennas.planar import PlanarPatchArray

    def pattern(**platform):
        scan = PPISector(
            name="scan",
            azimuth_start_deg=264.5,
            azimuth_stop_deg=265.5,
            elevation_deg=-1.0,
            **platform,
        )
        beams = scan.process({}, Chunk(beams=np.arange(1)))["beams"]
        antenna = PlanarPatchArray(
            name="a",
            n_x=8,
            n_y=8,
            spacing_x_m=0.0535,
            spacing_y_m=0.0535,
            face_azimuth_deg=270.0,
            grid_step_deg=0.5,
        )
        return beams, antenna.process({"beams": beams}, Chunk(beams=np.arange(1)))["pattern"]

    moving, on_board = pattern(platform="airborne", platform_heading_deg=320.0)
    _, still = pattern()
    assert moving["azimuth"].values[0] == pytest.approx(225.0)
    assert np.array_equal(on_board["power"].values, still["power"].values)


@pytest.mark.parametrize(
    ("kind", "mobile"), [("fixed", "false"), ("ship", "true"), ("aircraft", "true")]
)
def test_the_store_says_whether_its_platform_is_mobile(kind, mobile):
    """FM-301's ``platform_is_mobile`` follows the scan's ``platform_type``: a store of the
    airborne graph said "false" (provenance's still ground radar) before."""
    import xarray as xr

    from pasim_graph.provenance import provenance
    from pasim_graph.store import split_volume

    sweep = xr.Dataset(
        {"DBZH": (("beam", "range"), np.zeros((2, 3))), "platform_type": ((), kind)},
        coords={"azimuth": ("beam", [0.0, 1.0]), "range": [1.0, 2.0, 3.0]},
    )
    root, rest = split_volume(sweep, provenance("test", "pasim run"))
    assert root.attrs["platform_is_mobile"] == mobile
    assert str(root["platform_type"].values) == kind and "platform_type" not in rest
