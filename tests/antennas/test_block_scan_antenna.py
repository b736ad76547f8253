"""Tests of the scan and antenna blocks (``blocks/scan.py``, ``blocks/antenna.py``).

What each test compares against:

* PPI sector: the definition (beams centred in ``spacing`` steps clockwise from the start,
  wrapping through north; 360 / spacing beams for a full circle; dwell time M T per beam);
* alignment to the truth: a hand-made truth with radials at x.25 / x.75 deg (and a copy with
  +-0.02 deg jitter, as real NEXRAD radials have): beams must sit on truth radials and stay
  evenly spaced (all spacings equal within 0.05 deg);
* pencil beam: theory (peak 1 on axis, 3-dB points at +-beamwidth/2, the -32 dB first
  sidelobe of the paper's Table 4, H == V), an independent polar quadrature
  2 pi int P(theta)^2 sin(theta) dtheta of the two-way pattern, and the Probert-Jones
  Gaussian-beam approximation pi theta^2 / (8 ln 2) (see the test for the tolerance);
* planar patch array: the cavity-model patch element (Balanis ch. 14, formula written out
  here) at the steered beam axis, where the array factor equals its broadside peak, so the
  one-way H and V powers are the element's; and the aperture directivity
  10 log10(4 pi A / lambda^2 eta) with the Taylor taper from scipy.signal.windows.taylor
  (and ``pasim_blocks.antennas.array_factor.planar_array_directivity_db``).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.antennas.aperture import PencilBeam
from pasim_blocks.antennas.array_factor import planar_array_directivity_db
from pasim_blocks.antennas.pencil import PencilBeamAntenna
from pasim_blocks.antennas.planar import PlanarPatchArray
from pasim_blocks.scans.ppi import PPISector
from scipy import integrate
from scipy.signal.windows import taylor

from pasim_graph import Chunk

from ..conftest import assert_chunk_grids_are_each_beams_fields

C = 299_792_458.0


def scan(n: int | None = None, truth: xr.Dataset | None = None, **params) -> xr.Dataset:
    block = PPISector(name="scan", **params)
    beams = np.arange(block.beam_count() if n is None else n)
    inputs = {} if truth is None else {"truth": truth}
    return block.process(inputs, Chunk(beams=beams))["beams"]


def circular_spacing(az: np.ndarray) -> np.ndarray:
    return (np.diff(az) + 180.0) % 360.0 - 180.0


# ---- scan -------------------------------------------------------------------------------------


def test_sector_beam_count_and_azimuths() -> None:
    """240..330 deg at 1 deg: 90 beams centred at 240.5, 241.5, ..., 329.5."""
    block = PPISector(name="scan", azimuth_start_deg=240, azimuth_stop_deg=330)
    assert block.beam_count() == 90
    beams = scan(azimuth_start_deg=240, azimuth_stop_deg=330)
    np.testing.assert_allclose(beams["azimuth"].values, 240.5 + np.arange(90))
    assert beams.sizes["beam"] == 90


def test_sector_wrapping_through_north() -> None:
    """350..10 deg at 0.5 deg: 40 beams, 350.25 ... 359.75, 0.25 ... 9.75, all in [0, 360)."""
    beams = scan(azimuth_start_deg=350, azimuth_stop_deg=10, beam_spacing_deg=0.5)
    az = beams["azimuth"].values
    assert az.size == 40
    expected = np.concatenate([350.25 + 0.5 * np.arange(20), 0.25 + 0.5 * np.arange(20)])
    np.testing.assert_allclose(az, expected, atol=1e-9)
    assert np.all((az >= 0) & (az < 360))
    np.testing.assert_allclose(circular_spacing(az), 0.5, atol=1e-9)


@pytest.mark.parametrize("start", [0.0, 90.0])
def test_full_circle(start: float) -> None:
    """A sector whose stop equals its start (or 0..360) is the full circle: 360 / spacing beams,
    evenly spaced all round (the last beam is one spacing before the first)."""
    stop = 360.0 if start == 0.0 else start
    beams = scan(azimuth_start_deg=start, azimuth_stop_deg=stop, beam_spacing_deg=2.0)
    az = beams["azimuth"].values
    assert az.size == 180
    np.testing.assert_allclose(circular_spacing(np.append(az, az[0])), 2.0, atol=1e-9)
    assert az[0] == pytest.approx(start + 1.0)


def test_chunk_selects_its_beams_and_dwell_times() -> None:
    """A chunk gets the azimuths of its own beam indices, beam k starts k M T after the
    first, and PRT / pulses are passed on."""
    params = {"azimuth_start_deg": 10, "azimuth_stop_deg": 40, "pulses": 32, "prt_s": 1e-3}
    block = PPISector(name="scan", **params)
    beams = block.process({}, Chunk(beams=np.array([5, 6, 7])))["beams"]
    np.testing.assert_allclose(beams["azimuth"].values, [15.5, 16.5, 17.5])
    t = (beams["time"].values - np.datetime64("2000-01-01T00:00:00", "ns")) / np.timedelta64(1, "s")
    np.testing.assert_allclose(t, np.array([5, 6, 7]) * 32 * 1e-3, atol=1e-6)
    np.testing.assert_allclose(beams["prt"].values, 1e-3)
    assert int(beams["pulses"]) == 32
    np.testing.assert_allclose(beams["elevation"].values, 0.5)


def tiny_truth(azimuths: np.ndarray) -> xr.Dataset:
    """A truth sweep reduced to what the scan reads: radial azimuths, start time and site."""
    return xr.Dataset(
        {"DBZH": (("radial", "gate"), np.zeros((azimuths.size, 2), np.float32))},
        coords={"azimuth": ("radial", azimuths)},
        attrs={
            "time_coverage_start": "2013-05-20T20:00:00Z",
            "latitude": 35.33,
            "longitude": -97.28,
            "altitude": 370.0,
        },
    )


@pytest.mark.parametrize("jitter_deg", [0.0, 0.02])
@pytest.mark.parametrize(("start", "stop"), [(240.0, 330.0), (350.0, 10.0), (0.0, 360.0)])
def test_align_to_truth_keeps_even_spacing(start: float, stop: float, jitter_deg: float) -> None:
    """1-deg beams whose nominal centres (x.5) fall midway between 0.5-deg truth radials at
    x.25 / x.75: every beam must point at a truth radial and the spacing stay even (within
    0.05 deg, i.e. up to twice the radial jitter)."""
    rng = np.random.default_rng(8)
    radials = (np.arange(720) * 0.5 + 0.25 + rng.uniform(-1, 1, 720) * jitter_deg) % 360.0
    truth = tiny_truth(rng.permutation(radials))
    az = scan(truth=truth, azimuth_start_deg=start, azimuth_stop_deg=stop)["azimuth"].values
    assert np.all(np.min(np.abs(az[:, None] - radials[None, :]), axis=1) < 1e-9)
    spacing = circular_spacing(az)
    np.testing.assert_allclose(spacing, 1.0, atol=0.05)
    # And the whole scan moved by at most half a radial spacing (plus jitter).
    nominal = scan(azimuth_start_deg=start, azimuth_stop_deg=stop)["azimuth"].values
    assert np.all(np.abs((az - nominal + 180) % 360 - 180) <= 0.25 + 2 * jitter_deg + 1e-9)


def test_truth_sets_time_and_site_and_alignment_can_be_off() -> None:
    """With a truth connected the beams start at its time_coverage_start and carry its site;
    with align_to_truth false the azimuths stay nominal."""
    truth = tiny_truth(np.arange(720) * 0.5 + 0.25)
    beams = scan(n=3, truth=truth, align_to_truth=False, pulses=64, prt_s=1 / 300)
    np.testing.assert_allclose(beams["azimuth"].values, [240.5, 241.5, 242.5])
    assert beams["time"].values[0] == np.datetime64("2013-05-20T20:00:00", "ns")
    assert float(beams["latitude"]) == 35.33
    assert float(beams["longitude"]) == -97.28
    assert float(beams["altitude"]) == 370.0


# ---- pencil beam ------------------------------------------------------------------------------


def pencil(n_beams: int = 2, **params):
    beams = scan(n=n_beams)
    return PencilBeamAntenna(name="ant", **params).process(
        {"beams": beams}, Chunk(beams=np.arange(n_beams))
    )["pattern"]


def test_pencil_shape_peak_and_polarisations() -> None:
    """Shape (beam, 2, el, az); one-way power 1 on axis and nowhere above; H == V; the 3-dB
    points at +-beamwidth/2 on both axes; gain attribute = gain_db."""
    pattern = pencil(n_beams=3, grid_step_deg=0.05, support_deg=5.0)
    power = pattern["power"]
    assert power.dims == ("beam", "polarization", "elevation_offset", "azimuth_offset")
    assert power.shape == (3, 2, 201, 201)
    assert list(pattern["polarization"].values) == ["H", "V"]
    d_az = pattern["azimuth_offset_deg"].values
    d_el = pattern["elevation_offset_deg"].values
    i0, j0 = np.argmin(np.abs(d_el)), np.argmin(np.abs(d_az))
    assert d_az[j0] == 0 and d_el[i0] == 0
    p = power.values
    np.testing.assert_allclose(p[:, :, i0, j0], 1.0, atol=1e-6)
    assert p.max() <= 1.0 + 1e-6
    np.testing.assert_array_equal(p[:, 0], p[:, 1])
    for axis_cut, offsets in ((p[0, 0, i0, :], d_az), (p[0, 0, :, j0], d_el)):
        for half in (-0.5, 0.5):
            assert np.interp(half, offsets, axis_cut) == pytest.approx(0.5, abs=2e-3)
    assert pattern.attrs["gain_db"] == 45.5


def test_pencil_first_sidelobe_is_table_4() -> None:
    """First sidelobe of the azimuth cut: -32 dB (paper Table 4), within 0.1 dB on a
    0.01-deg grid (sampling a sidelobe ~0.6 deg wide that finely costs < 0.01 dB)."""
    pattern = pencil(n_beams=1, grid_step_deg=0.01, support_deg=2.5)
    d_el = pattern["elevation_offset_deg"].values
    cut = pattern["power"].values[0, 0, np.argmin(np.abs(d_el)), :]
    right = cut[cut.size // 2 :]
    null = np.argmax(np.diff(right) > 0)  # first minimum going outwards
    sidelobe_db = 10 * np.log10(right[null:].max())
    assert sidelobe_db == pytest.approx(-32.0, abs=0.1)


def test_pencil_solid_angle_quadrature_and_probert_jones() -> None:
    """Two-way solid angle attribute vs (a) a polar quadrature of the same pattern model,
    2 pi int_0^10deg P(theta)^2 sin(theta) dtheta, within 0.1 % (the block sums a 0.05-deg
    az/el grid with cos(el) weights), and (b) Probert-Jones' pi theta^2 / (8 ln 2), within
    3 %. (b) is exact only for a Gaussian beam: the -32 dB tapered-aperture main lobe falls
    faster than a Gaussian outside the half-power points, so the true integral is about
    1.5 % smaller; the two-way sidelobes (-64 dB) add only ~1e-6 of the total."""
    pattern = pencil(n_beams=1)
    omega = pattern.attrs["two_way_solid_angle_sr_H"]
    assert pattern.attrs["two_way_solid_angle_sr_V"] == omega
    beam = PencilBeam.design(1.0, -32.0)
    theta = np.linspace(0.0, 10.0, 100_001)
    integrand = beam.power(theta) ** 2 * np.sin(np.deg2rad(theta))
    polar = 2 * np.pi * integrate.simpson(integrand, x=np.deg2rad(theta))
    assert omega == pytest.approx(polar, rel=1e-3)
    probert_jones = np.pi * np.deg2rad(1.0) ** 2 / (8 * np.log(2))
    assert omega == pytest.approx(probert_jones, rel=0.03)
    assert omega < probert_jones  # the direction of the main-lobe-shape difference
    # The solid angle scales with the beamwidth squared (same taper, scaled aperture).
    wide = pencil(n_beams=1, beamwidth_deg=2.0, grid_step_deg=0.1)
    assert wide.attrs["two_way_solid_angle_sr_H"] == pytest.approx(4 * omega, rel=5e-3)


def test_pencil_pattern_follows_beam_elevation() -> None:
    """A beam at 30 deg elevation: an azimuth offset d is a great-circle angle
    2 asin(cos(el) sin(d/2)), so the half-power azimuth offset is 2 asin(sin(0.25 deg) /
    cos 30 deg) = 0.577 deg, and the two-way pattern integrated as the weather channel does
    (sum P^2 cos(el + d_el) d_az d_el) equals the solid angle attribute (within 0.1 %)."""
    elevation = 30.0
    beams = scan(n=1, elevation_deg=elevation)
    pattern = PencilBeamAntenna(name="ant", support_deg=3.0).process(
        {"beams": beams}, Chunk(beams=np.arange(1))
    )["pattern"]
    d_az = pattern["azimuth_offset_deg"].values
    d_el = pattern["elevation_offset_deg"].values
    p = pattern["power"].values[0, 0].astype(np.float64)
    half_power_az = 2 * np.degrees(np.arcsin(np.sin(np.radians(0.25)) / np.cos(np.radians(30))))
    cut = p[np.argmin(np.abs(d_el))]
    assert np.interp(half_power_az, d_az, cut) == pytest.approx(0.5, abs=5e-3)
    step = np.radians(d_az[1] - d_az[0]) * np.radians(d_el[1] - d_el[0])
    integral = np.sum(p**2 * np.cos(np.radians(elevation + d_el))[:, None]) * step
    assert integral == pytest.approx(pattern.attrs["two_way_solid_angle_sr_H"], rel=1e-3)


# ---- planar patch array -----------------------------------------------------------------------

ARRAY = {
    "n_x": 16,
    "n_y": 16,
    "grid_step_deg": 0.2,
    "face_azimuth_deg": 285.0,
    "spacing_x_m": 0.0524,
    "spacing_y_m": 0.0524,
    "patch_m": 0.035,
    "frequency_hz": 2.8e9,
    "taylor_sll_db": -30.0,
    "taylor_nbar": 5,
}


def planar(azimuths: list[float]) -> xr.Dataset:
    """Beams built by hand: only azimuth and elevation are read by the array."""
    beams = xr.Dataset(
        coords={
            "azimuth": ("beam", np.array(azimuths)),
            "elevation": ("beam", np.zeros(len(azimuths))),
        }
    )
    return PlanarPatchArray(name="array", **ARRAY).process(
        {"beams": beams}, Chunk(beams=np.arange(len(azimuths)))
    )["pattern"]


def patch_powers(scan_deg: float) -> tuple[float, float]:
    """One-way H and V co-polar power of the cavity-model patch in the horizontal plane,
    ``scan_deg`` off the face normal (Balanis ch. 14, two slots L apart, L long):
    E_H = cos(pi L/lambda sin t) (E-plane), E_V = sinc(L/lambda sin t) cos t (H-plane)."""
    size = ARRAY["patch_m"] * ARRAY["frequency_hz"] / C
    s = np.sin(np.deg2rad(scan_deg))
    e_h = np.cos(np.pi * size * s)
    e_v = np.sinc(size * s) * np.cos(np.deg2rad(scan_deg))
    return float(e_h**2), float(e_v**2)


def test_planar_broadside_h_equals_v_with_unit_peak() -> None:
    """Broadside beam: H == V == 1 on the axis (element 1 at broadside, patterns normalised
    to the broadside peak) and nowhere above 1."""
    pattern = planar([285.0])
    p = pattern["power"].values[0]
    c = p.shape[-1] // 2
    assert pattern["azimuth_offset_deg"].values[c] == pytest.approx(0.0, abs=1e-12)
    assert p[0, c, c] == pytest.approx(1.0, abs=1e-5)
    assert p[1, c, c] == pytest.approx(1.0, abs=1e-5)
    assert p.max() <= 1.0 + 1e-5


def test_planar_scan_loss_and_zdr_bias_off_broadside() -> None:
    """Steered 30 deg off the normal: on the axis the array factor equals its broadside peak,
    so P_H and P_V are the patch element's powers at 30 deg (both below 1: scan loss) and
    the two-way H/V ratio (P_H/P_V)^2 is theirs, 0.88 dB here, not 0 dB."""
    pattern = planar([285.0, 315.0])
    p = pattern["power"].values[1]
    c = p.shape[-1] // 2
    e_h, e_v = patch_powers(30.0)
    assert p[0, c, c] == pytest.approx(e_h, rel=1e-4)
    assert p[1, c, c] == pytest.approx(e_v, rel=1e-4)
    two_way_ratio_db = 20 * np.log10(p[0, c, c] / p[1, c, c])
    assert two_way_ratio_db == pytest.approx(20 * np.log10(e_h / e_v), abs=1e-3)
    assert abs(two_way_ratio_db) > 0.5
    broadside_peak = pattern["power"].values[0].max(axis=(1, 2))
    assert np.all(p.max(axis=(1, 2)) < 0.8 * broadside_peak)  # scan loss of ~1.2-1.6 dB


def test_planar_chunk_grids_are_each_beams_own_fields() -> None:
    """A chunk's grids, written beam by beam into one array, are each beam's own fields, for
    an impaired array (channel errors, quantised phase shifters: the exact non-separable
    path) as for an ideal one."""
    for extra in ({}, {"phase_bits": 4, "phase_error_deg": 5.0, "amplitude_error_db": 0.5}):
        block = PlanarPatchArray(name="array", **ARRAY, **extra)
        block.setup()
        az, el = np.array([285.0, 300.5, 262.0]), np.array([0.5, 0.5, 3.0])
        assert_chunk_grids_are_each_beams_fields(block, az, el, 7)


def test_planar_gain_is_aperture_directivity() -> None:
    """gain_db = planar_array_directivity_db and = 10 log10(4 pi A / lambda^2 eta_x eta_y),
    eta = |sum w|^2 / (N sum w^2) of scipy's Taylor window (nbar 5, 30 dB)."""
    pattern = planar([285.0])
    expected = planar_array_directivity_db(
        n_x=16,
        n_y=16,
        dx_m=0.0524,
        dy_m=0.0524,
        frequency_hz=2.8e9,
        taylor_sll_db=-30.0,
        taylor_nbar=5,
    )
    assert pattern.attrs["gain_db"] == pytest.approx(expected, abs=1e-9)
    w = taylor(16, nbar=5, sll=30, norm=False)
    eta = w.sum() ** 2 / (w.size * np.sum(w**2))
    area = (16 * 0.0524) ** 2
    lam = C / 2.8e9
    assert pattern.attrs["gain_db"] == pytest.approx(
        10 * np.log10(4 * np.pi * area / lam**2 * eta**2), abs=1e-6
    )
    # Solid angles (broadside) are reported for both polarisations and agree closely.
    om_h = pattern.attrs["two_way_solid_angle_sr_H"]
    om_v = pattern.attrs["two_way_solid_angle_sr_V"]
    assert om_h == pytest.approx(om_v, rel=1e-3)
