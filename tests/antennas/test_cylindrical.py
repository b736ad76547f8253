"""Tests of the cylindrical array (``antenna.cylindrical``, ``blocks/cylindrical.py``).

What each test compares against:

* the paper's Table 6 (one-way azimuth 3-dB beamwidth and first sidelobe of the 10-m and the
  2-m CPPAR), measured on azimuth cuts of the block's own patterns;
* commutation: beams 30 deg apart (52 columns) have the same pattern, beams half a column
  apart nearly the same, while the planar array loses gain 30 deg off broadside;
* the H/V mismatch predicted from the cavity-model patch formulas written out here;
* the gain: a brute-force sum over every element's position integrated over the sphere
  (independent code), the projected-aperture directivity, and the pattern grid's integral;
* ``pasim run`` / ``pasim score`` end to end on the bundled scene.
"""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.antennas.cylindrical import CylindricalArray, taylor_continuous
from pasim_blocks.antennas.geometry import face_geometry, patch_field
from pasim_blocks.antennas.measured import TabulatedPattern
from pasim_blocks.antennas.measures import first_sidelobe_db, half_power_beamwidth_deg
from pasim_blocks.antennas.pattern_files import write_pattern_file
from pasim_blocks.antennas.planar import PlanarPatchArray
from scipy.signal.windows import taylor

from pasim_graph import Chunk
from pasim_graph.memo import SHARED

from ..conftest import GRAPHS, assert_chunk_grids_are_each_beams_fields, run_cli

C = 299_792_458.0
LAMBDA = C / 2.8e9
SIZE = 0.0524 / LAMBDA  # patch side in wavelengths
COLUMN_DEG = 360.0 / 624


def beams(azimuths, elevation_deg: float = 0.5) -> xr.Dataset:
    """Beams built by hand: only azimuth and elevation are read by the antennas."""
    az = np.asarray(azimuths, dtype=float)
    return xr.Dataset(
        coords={"azimuth": ("beam", az), "elevation": ("beam", np.full(az.size, elevation_deg))}
    )


def patterns(block, azimuths, elevation_deg: float = 0.5) -> xr.Dataset:
    b = beams(azimuths, elevation_deg)
    return block.process({"beams": b}, Chunk(beams=np.arange(b.sizes["beam"])))["pattern"]


def centre_near(azimuth_deg: float, column_deg: float = COLUMN_DEG) -> float:
    """The even sector's centre (midway between two columns) nearest ``azimuth_deg``."""
    return (np.round(azimuth_deg / column_deg - 0.5) + 0.5) * column_deg


def azimuth_cut(pattern: xr.Dataset, beam: int, pol: int) -> tuple[np.ndarray, np.ndarray]:
    d_el = pattern["elevation_offset_deg"].values
    cut = pattern["power"].values[beam, pol, np.argmin(np.abs(d_el))].astype(float)
    return pattern["azimuth_offset_deg"].values, cut


@pytest.fixture(scope="module")
def cppar10() -> CylindricalArray:
    """The graph's array (defaults are the 10-m CPPAR of Table 6)."""
    return CylindricalArray(name="antenna")


# ---- Table 6 ----------------------------------------------------------------------------------


def test_beamwidth_and_first_sidelobe_match_table_6() -> None:
    """10-m CPPAR, H port, beam on the sector centre at 0 deg elevation: one-way azimuth
    beamwidth 1.1 deg and first sidelobe -30.5 dB in Table 6. Measured (0.02-deg cut)
    1.015 deg and -30.51 dB. Tolerances: 0.1 deg and 0.5 dB. The paper gives one decimal and
    does not say how its taper was sampled or how its patch was modelled. This taper (a 30-dB
    Taylor sampled per column) matches the sidelobe and gives a beam 8 % narrower; neither a
    Taylor taper per column nor one over the projected aperture gives 1.1 deg with a -30.5 dB
    sidelobe (`docs/physics.md` has the scan)."""
    block = CylindricalArray(name="a", grid_step_deg=0.02, support_deg=3.0)
    pattern = patterns(block, [centre_near(285.0)], elevation_deg=0.0)
    d_az, cut = azimuth_cut(pattern, 0, 0)
    assert half_power_beamwidth_deg(d_az, cut) == pytest.approx(1.1, abs=0.1)
    assert first_sidelobe_db(d_az, cut) == pytest.approx(-30.5, abs=0.5)
    # The measured values stated in the docs (regression, tight).
    assert half_power_beamwidth_deg(d_az, cut) == pytest.approx(1.015, abs=0.005)
    assert first_sidelobe_db(d_az, cut) == pytest.approx(-30.51, abs=0.05)


def test_same_design_gives_the_2m_row_of_table_6() -> None:
    """The same taper rule on the 2-m demonstrator (96 columns, 24 excited): Table 6 gives
    5.2 deg and -30.1 dB. Measured 5.06 deg and -30.44 dB, within 0.2 deg (4 %) and 0.5 dB."""
    block = CylindricalArray(
        name="a", diameter_m=2.0, columns=96, excited_columns=24, support_deg=12.0
    )
    pattern = patterns(block, [centre_near(100.0, 360.0 / 96)], elevation_deg=0.0)
    d_az, cut = azimuth_cut(pattern, 0, 0)
    assert half_power_beamwidth_deg(d_az, cut) == pytest.approx(5.2, abs=0.2)
    assert first_sidelobe_db(d_az, cut) == pytest.approx(-30.1, abs=0.5)


# ---- commutation ------------------------------------------------------------------------------


def test_pattern_is_azimuth_invariant(cppar10) -> None:
    """Beams 30 deg apart (52 columns) sit at the same offset from their sector centres, so
    their patterns are identical. Half a column apart (the largest offset), the peak and the
    two-way solid angles change by under 0.005 dB and the main lobe (above -20 dB) by under
    0.01 dB (measured 0.0002, 0.0004 and 0.0023 dB). For contrast, the 80x80 planar array
    steered 30 deg off broadside loses over 2 dB of one-way peak power (scan loss)."""
    a = centre_near(285.0)
    pattern = patterns(cppar10, [a, a + 30.0, a + COLUMN_DEG / 2])
    p = pattern["power"].values.astype(float)
    np.testing.assert_array_equal(p[0], p[1])
    main = p[0] > 0.01
    assert np.max(np.abs(10 * np.log10(p[2][main] / p[0][main]))) < 0.01
    assert abs(10 * np.log10(p[2].max() / p[0].max())) < 0.005
    d_el = pattern["elevation_offset_deg"].values
    omega = np.sum(p**2 * np.cos(np.deg2rad(0.5 + d_el))[:, None], axis=(2, 3))  # beam x pol
    assert np.max(np.abs(10 * np.log10(omega[2] / omega[0]))) < 0.005

    planar = PlanarPatchArray(name="p", grid_step_deg=0.2, support_deg=3.0)
    q = patterns(planar, [285.0, 255.0])["power"].values
    assert 10 * np.log10(q[1, 0].max() / q[0, 0].max()) < -2.0


def test_offsets_are_cached_and_dropped_when_pickled(cppar10) -> None:
    """A 90-beam sector at the truth's irregular azimuths needs at most 13 patterns per
    elevation (offsets rounded to 1/12 of a column), and the memo does not travel to a
    worker."""
    rng = np.random.default_rng(3)
    az = 240.5 + np.arange(90) + rng.uniform(-0.3, 0.3, 90)
    block = CylindricalArray(name="a", grid_step_deg=0.1, support_deg=3.0)
    pattern = patterns(block, az)
    assert pattern.sizes["beam"] == 90
    assert len({k for k in block._memo if k[2] == 0.5}) <= 13
    clone = pickle.loads(pickle.dumps(block))
    assert clone._memo is None
    again = patterns(clone, az[:3])
    np.testing.assert_array_equal(again["power"].values, pattern["power"].values[:3])


def test_grids_are_shared_by_equal_arrays_only(tmp_path) -> None:
    """A study's next run (or a worker's) builds the same array again: it takes the grids the
    first instance made (the same read-only arrays, bit-identical to its own; under the other
    calibration too), while an array differing in a parameter, in its element file's contents
    (same path, edited between runs) or drawing random channel errors computes its own."""
    SHARED.clear()
    common = {"grid_step_deg": 0.1, "support_deg": 3.0}
    az = [240.3, 241.1, 242.4]
    first = CylindricalArray(name="a", **common)
    a = patterns(first, az)
    again = CylindricalArray(name="a", **common)
    assert pickle.loads(pickle.dumps(again))._memo is None
    b = patterns(again, az)
    assert SHARED.hits >= 3
    beam_keys = [k for k in again._memo if k[2] == 0.5]  # not the reference made in set-up
    assert beam_keys and all(again._memo[k] is first._memo[k] for k in beam_keys)
    assert not again._memo[beam_keys[0]].flags.writeable
    np.testing.assert_array_equal(a["co_polar"].values, b["co_polar"].values)
    SHARED.clear()  # a fresh instance, nothing shared: the same bits
    alone = patterns(CylindricalArray(name="a", **common), az)
    np.testing.assert_array_equal(a["co_polar"].values, alone["co_polar"].values)

    other = patterns(CylindricalArray(name="a", taylor_sll_db=-25.0, **common), az)
    assert not np.array_equal(a["co_polar"].values, other["co_polar"].values)

    # The calibration choice sets the radar constant, not the grids: an array under the
    # other one (a study's calibration run) takes them, and made alone they are the same.
    hits = SHARED.hits
    boresight = CylindricalArray(name="a", calibration="boresight", **common)
    taken = patterns(boresight, az)
    assert SHARED.hits > hits
    SHARED.clear()
    own_block = CylindricalArray(name="a", calibration="boresight", **common)
    own = patterns(own_block, az)
    np.testing.assert_array_equal(taken["co_polar"].values, own["co_polar"].values)
    np.testing.assert_array_equal(taken["co_polar"].values, a["co_polar"].values)

    hits = SHARED.hits
    errors = {"phase_error_deg": 5.0, "amplitude_error_db": 0.5}
    drawn = [CylindricalArray(name="a", **errors, **common) for _ in range(2)]
    # Each takes its design's broadside figures (its ideal copy's: the array measured just
    # above, but for the calibration, which changes none of them), and nothing else.
    assert SHARED.hits == hits + len(drawn)
    assert all(b.gain_db == own_block.gain_db and b.omega == own_block.omega for b in drawn)
    hits = SHARED.hits
    for block in drawn:
        patterns(block, az)
    assert SHARED.hits == hits  # random electronics: no grid kept, none taken

    size = 0.0524 * 2.8e9 / C
    el = np.arange(-60.0, 60.001, 1.0)
    azimuths = np.arange(-90.0, 90.001, 1.0)
    f = patch_field(face_geometry(azimuths[None, :], el[:, None], 0.0, 0.0), size)
    shape = (el.size, azimuths.size)
    path = tmp_path / "element.csv"
    out = []
    for tilt in (0.0, 0.5):  # the file edited between two runs of the same graph
        gain = np.exp(tilt * np.deg2rad(azimuths))[None, :]
        values = np.stack([np.broadcast_to(np.asarray(c, complex), shape) * gain for c in f])
        write_pattern_file(path, TabulatedPattern(azimuths, el, values))
        block = CylindricalArray(name="a", element="file", element_file=str(path), **common)
        resource = block.load()
        b = beams(az)
        chunk = Chunk(beams=np.arange(len(az)), resource=resource)
        out.append(block.process({"beams": b}, chunk)["pattern"]["co_polar"].values)
    assert not np.array_equal(out[0], out[1])


# ---- H / V ------------------------------------------------------------------------------------


def test_h_v_mismatch_is_the_patch_e_and_h_planes(cppar10) -> None:
    """The patch's H port falls off in the E-plane, cos(pi L sin d), faster than the V port in
    its H-plane, sinc(L sin d) cos d, so the V port weights the sector edges more: its peak is
    higher by (sum a E_V / sum a E_H)^2 (0.30 dB), its beam narrower and its first sidelobe
    higher. The offset is the same for every beam, so the calibration removes it: the two-way
    H/V solid-angle ratio of beams 30 deg and half a column apart agrees within 0.002 dB."""
    a = centre_near(285.0)
    pattern = patterns(cppar10, [a, a + 30.0, a + COLUMN_DEG / 2], elevation_deg=0.0)
    d = (np.arange(156) - 77.5) * COLUMN_DEG
    s = np.sin(np.deg2rad(d))
    w = taylor(156, nbar=5, sll=30, norm=False)
    e_h = np.cos(np.pi * SIZE * s)
    e_v = np.sinc(SIZE * s) * np.cos(np.deg2rad(d))
    predicted_db = 20 * np.log10(np.sum(w * e_v) / np.sum(w * e_h))
    p = pattern["power"].values.astype(float)
    assert 10 * np.log10(p[0, 1].max() / p[0, 0].max()) == pytest.approx(predicted_db, abs=1e-3)
    assert 0.2 < predicted_db < 0.4
    d_az, cut_h = azimuth_cut(pattern, 0, 0)
    _, cut_v = azimuth_cut(pattern, 0, 1)
    assert half_power_beamwidth_deg(d_az, cut_v) < half_power_beamwidth_deg(d_az, cut_h) - 0.01
    assert first_sidelobe_db(d_az, cut_v) > first_sidelobe_db(d_az, cut_h) + 1.0
    ratio_db = 10 * np.log10(np.sum(p[:, 0] ** 2, axis=(1, 2)) / np.sum(p[:, 1] ** 2, axis=(1, 2)))
    assert np.ptp(ratio_db) < 0.002
    assert abs(ratio_db[0]) > 0.3  # the offset itself is not small


# ---- gain -------------------------------------------------------------------------------------


def brute_force_directivity_db(
    diameter_m: float, columns: int, excited: int, per_column: int, n_az: int, n_v: int
) -> float:
    """4 pi / (sphere integral of the H power) for a beam on the sector centre at 0 deg, from
    the field summed over every element position (no convolution, no spline): midpoint rule in
    azimuth, Gauss-Legendre in v = sin(el). Uniform vertical weights, 0.0524 m apart."""
    k, r = 2 * np.pi / LAMBDA, diameter_m / 2
    phi = (np.arange(excited) - (excited - 1) / 2) * 360.0 / columns
    a = taylor(excited, nbar=5, sll=30, norm=False)
    w = a * np.exp(-1j * k * r * np.cos(np.deg2rad(phi)))
    az = (np.arange(n_az) + 0.5) * 360.0 / n_az - 180.0
    v, gl = np.polynomial.legendre.leggauss(n_v)
    cos_el = np.sqrt(1 - v**2)
    z = (np.arange(per_column) - (per_column - 1) / 2) * 0.0524
    vertical = np.abs(np.exp(1j * k * np.outer(v, z)).sum(axis=1)) ** 2 / per_column**2
    d = np.deg2rad(az[None, :, None] - phi)  # direction x column, every row
    u = cos_el[:, None, None] * np.sin(d)
    e_h = np.where(np.cos(d) > 0, np.cos(np.pi * SIZE * u) * np.sinc(SIZE * v[:, None, None]), 0)
    e_h = e_h * cos_el[:, None, None]  # projection of the H port's field on the local h
    field = np.sum(w * e_h * np.exp(1j * k * r * cos_el[:, None, None] * np.cos(d)), axis=-1)
    peak = np.sum(a * np.cos(np.pi * SIZE * np.sin(np.deg2rad(phi))))
    per_v = np.sum(np.abs(field / peak) ** 2, axis=1) * np.deg2rad(360.0 / n_az)
    return float(10 * np.log10(4 * np.pi / np.sum(gl * vertical * per_v)))


def test_gain_is_the_sphere_integral_of_the_pattern() -> None:
    """A 2-m array (96 columns, 24 excited, 16 uniform elements per column): the block's gain
    (FFT over the circle, splined azimuth integral) against the brute-force element sum
    integrated over the sphere, within 0.01 dB."""
    block = CylindricalArray(
        name="a",
        diameter_m=2.0,
        columns=96,
        excited_columns=24,
        elements_per_column=16,
        taylor_sll_y_db=-13.0,
        taylor_nbar_y=1,
        grid_step_deg=0.25,
    )
    np.testing.assert_allclose(block.taper_y, 1.0)  # nbar 1: uniform, as the brute force
    expected = brute_force_directivity_db(2.0, 96, 24, 16, n_az=480, n_v=256)
    assert block.gain_db == pytest.approx(expected, abs=0.01)


def test_gain_against_aperture_and_grid(cppar10) -> None:
    """10-m CPPAR: gain 45.63 dBi. (a) The projected aperture 4 pi W H eta_x eta_y / lambda^2
    (W = D sin 45 deg = 7.07 m, H = 128 x 0.0524 m, Taylor efficiencies) gives 45.80 dBi. The
    block must be lower, by less than 0.5 dB: the patches at the sector edges face up to 45 deg
    away, which tapers the aperture further. (b) 4 pi over the one-way pattern integrated on the
    +-10 deg grid misses only the far sidelobes, so it is higher, by less than 0.05 dB."""
    gain = cppar10.gain_db
    assert gain == pytest.approx(45.63, abs=0.01)
    w_x = taylor(156, nbar=5, sll=30, norm=False)
    w_y = taylor(128, nbar=5, sll=30, norm=False)
    eta = (w_x.sum() ** 2 / (156 * np.sum(w_x**2))) * (w_y.sum() ** 2 / (128 * np.sum(w_y**2)))
    aperture_db = 10 * np.log10(
        4 * np.pi * 10.0 * np.sin(np.pi / 4) * 128 * 0.0524 * eta / LAMBDA**2
    )
    assert 0.0 < aperture_db - gain < 0.5
    pattern = patterns(cppar10, [centre_near(285.0)], elevation_deg=0.0)
    assert pattern.attrs["gain_db"] == gain
    p = pattern["power"].values[0, 0].astype(float)
    d_az = pattern["azimuth_offset_deg"].values
    d_el = pattern["elevation_offset_deg"].values
    integral = (
        np.sum(p * np.cos(np.deg2rad(d_el))[:, None])
        * np.deg2rad(d_az[1] - d_az[0])
        * np.deg2rad(d_el[1] - d_el[0])
    )
    grid_db = 10 * np.log10(4 * np.pi / integral)
    assert 0.0 < grid_db - gain < 0.05


# ---- configuration and helpers ----------------------------------------------------------------


def test_continuous_taylor_reproduces_scipy_at_cell_centres() -> None:
    cells = (np.arange(40) - 20 + 0.5) / 40
    np.testing.assert_allclose(
        taylor_continuous(cells, 40, -30.0, 5), taylor(40, nbar=5, sll=30, norm=True), atol=1e-12
    )


def test_projected_taper_is_a_valid_alternative() -> None:
    """The Taylor taper sampled at the projected column positions: the element pattern adds
    its edge taper on top, so the first sidelobe falls far below the design (about -39 dB for
    a 30-dB design) and the beam widens."""
    block = CylindricalArray(name="a", taper_axis="projected", grid_step_deg=0.02, support_deg=3.0)
    d_az, cut = azimuth_cut(patterns(block, [centre_near(285.0)], elevation_deg=0.0), 0, 0)
    assert first_sidelobe_db(d_az, cut) < -36.0
    assert half_power_beamwidth_deg(d_az, cut) > 1.02


def test_check_config() -> None:
    assert CylindricalArray.check_config({"columns": 100, "excited_columns": 101}, set())
    assert CylindricalArray.check_config(
        {"columns": 100, "excited_columns": 50, "taper_axis": "projected"}, set()
    )
    assert not CylindricalArray.check_config({}, set())


# ---- end to end -------------------------------------------------------------------------------


# 30 s: the 10 m CPPAR's graph is run on two beams in the default suite
# (tests/engine/test_port_schemas.py's fingerprints); its whole sector with -m slow.
@pytest.mark.slow
def test_cppar10_graph_runs_and_scores(tmp_path) -> None:
    out = tmp_path / "cppar.zarr"
    graph = str(GRAPHS / "cppar10_radar.yaml")
    res = run_cli("run", graph, "--sector", "280:284", "--set", "scan.pulses=16", "--out", str(out))
    assert res.returncode == 0, res.stderr
    res = run_cli("score", str(out), "--json")
    assert res.returncode == 0, res.stderr
    dbzh = json.loads(res.stdout)["DBZH"]
    assert dbzh["count"] > 500
    assert np.isfinite(dbzh["std"]) and 0.5 < dbzh["std"] < 5.0


def test_chunk_grids_are_each_beams_own_fields() -> None:
    """A chunk's grids, written beam by beam into one array, are each beam's own fields (its
    sector's grid), ideal and with channel errors (the impaired path)."""
    for extra in ({}, {"phase_error_deg": 5.0, "amplitude_error_db": 0.5, "phase_bits": 4}):
        block = CylindricalArray(name="a", grid_step_deg=0.1, support_deg=3.0, **extra)
        block.setup()
        az, el = np.array([285.0, 287.3, 140.0]), np.array([0.5, 0.5, 2.0])
        assert_chunk_grids_are_each_beams_fields(block, az, el, 3)
