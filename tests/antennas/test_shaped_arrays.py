"""Tests of the arrays of any geometry (``antenna.linear``, ``antenna.ring``,
``antenna.lattice``, ``antenna.conformal``: ``blocks/antennas/conformal.py``, ``shaped.py``,
``layouts.py``).

What each test compares against:

* a full ring of omnidirectional elements: the closed form, ``J0(2 k a sin(dphi / 2))``
  (Balanis, *Antenna Theory*, 3rd ed., eq. 6-119 in the plane of the ring);
* the 10 m CPPAR written as a file of element positions and normals
  (``graphs/cppar10_elements.csv``): ``antenna.cylindrical`` with the same parameters
  (``graphs/cppar10_radar.yaml``), an independent implementation (column sums by FFT);
* a uniform line's half-power width: ``0.886 lambda / (N d cos theta)`` (Balanis eq. 6-22a
  with the scan broadening of the projected aperture);
* the rectangular lattice: ``antenna.planar`` with the same parameters (separable array
  factors, its own channel model), including errors, failures, quantised shifters and
  attenuators and subarrays;
* the triangular lattice: where its reciprocal lattice puts the grating lobes (worked out in
  the test);
* the gain: a brute-force integral of the pattern on a fine azimuth-elevation grid;
* ``pasim validate`` / ``pasim pattern`` / the study's pattern tools on the new graphs.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.antennas.beam_figures import build
from pasim_blocks.antennas.layouts import (
    lattice_layout,
    layout_from_elements,
    read_element_file,
    ring_layout,
    write_element_file,
)
from pasim_blocks.antennas.measures import half_power_beamwidth_deg
from pasim_blocks.antennas.planar import PlanarPatchArray
from pasim_blocks.antennas.shaped import ElementFileArray, LatticeArray, LinearArray, RingArray
from scipy.special import j0

from pasim_graph import Chunk, load

from ..conftest import GRAPHS, pasim, pasim_out

C = 299_792_458.0
LAMBDA = C / 2.8e9
K = 2 * np.pi / LAMBDA
ELEMENTS_CSV = str(GRAPHS / "cppar10_elements.csv")


def db(x: np.ndarray) -> np.ndarray:
    return 20 * np.log10(np.abs(x))


# ---- the must-shows ---------------------------------------------------------------------------


def test_full_ring_azimuth_pattern_is_the_bessel_j0_closed_form():
    """64 omnidirectional elements on a ring of ka = 25.6 (0.4 lambda apart), uniform, every
    element active: the azimuth pattern over +-30 deg of the beam equals |J0(2 k a sin(dphi /
    2))| (Balanis 6-119) within 0.5 dB (the neglected terms are J_64 and beyond)."""
    radius = 25.6 / K
    ring = RingArray(
        name="ring",
        elements=64,
        radius_m=radius,
        element="omni",
        taper="uniform",
        active_sector_deg=360.0,
        support_deg=1.0,
        grid_step_deg=0.5,
    )
    d = np.linspace(-30.0, 30.0, 1201)
    for steer in (285.0, 12.3):
        f = ring.fields_at(steer, 0.0, steer + d, np.zeros_like(d))
        closed = j0(2 * K * radius * np.sin(np.deg2rad(d) / 2))
        # Normalised to its own peak: the closed form is 1 on the beam.
        got = db(f.h_co) - db(f.h_co).max()
        assert np.max(np.abs(got - db(closed))) < 0.5
        assert np.max(np.abs(db(f.v_co) - db(f.h_co))) < 1e-9  # omni: both ports alike


def _cylinders(**overrides):
    cylinder = build(load(GRAPHS / "cppar10_radar.yaml"), "antenna")
    conformal = build(
        load(GRAPHS / "conformal_file.yaml"), "antenna", path=ELEMENTS_CSV, **overrides
    )
    return cylinder, conformal, conformal.load()


def test_small_cylinder_from_an_element_file_equals_antenna_cylindrical(tmp_path):
    """A 64-column cylinder of 8 elements a column written as element positions and normals
    (one channel a column, column feed steered), against antenna.cylindrical with the same
    parameters (its own code): azimuth and elevation cuts, both ports, over the main lobe and
    first sidelobes (within 45 dB of the peak), within 0.05 dB, with and without channel
    errors (the same column draws: channel = column)."""
    from pasim_blocks.antennas.cylindrical import CylindricalArray

    columns, per_column, diameter = 64, 8, 1.07
    path = tmp_path / "cylinder.csv"
    step = 360.0 / columns
    write_element_file(
        path,
        ring_layout(columns, diameter / 2, 360.0, (columns - 1) / 2 * step, per_column, 0.0524),
    )
    errors = dict(amplitude_error_db=0.5, phase_error_deg=5.0, failure_probability=0.05)
    for impaired in ({}, errors):
        cylinder = CylindricalArray(
            name="antenna", columns=columns, diameter_m=diameter, excited_columns=16,
            elements_per_column=per_column, **impaired,
        )  # fmt: skip
        conformal = ElementFileArray(
            name="antenna", path=str(path), active_sector_deg=90.0, subarray_feed="steered",
            broadside_azimuth_deg=cylinder.broadside()[0], **impaired,
        )  # fmt: skip
        resource = conformal.load()
        d = np.arange(-30.0, 30.0001, 0.2)
        for steer in (cylinder.broadside(), (100.0 + 0.3 * step, 4.0)):
            for az, el in (
                (steer[0] + d, np.full_like(d, steer[1])),
                (np.full_like(d, steer[0]), steer[1] + d),
            ):
                a = cylinder.fields_at(*steer, az, el, 2)
                b = conformal.fields_at(*steer, az, el, 2, resource)
                for port in ("h_co", "v_co"):
                    ref, got = db(getattr(a, port)), db(getattr(b, port))
                    lobes = ref > ref.max() - 45.0
                    assert np.max(np.abs(got - ref)[lobes]) < 0.05, (impaired, steer, port)


@pytest.mark.slow
def test_cylinder_from_its_element_file_equals_antenna_cylindrical():
    """graphs/conformal_file.yaml's antenna (the 10 m CPPAR as 79,872 element positions and
    normals) against graphs/cppar10_radar.yaml's antenna.cylindrical: azimuth and elevation
    cuts of both ports over the main lobe and first sidelobes (+-4 deg: the first sidelobes
    are 1.5-2 deg out) agree within 0.05 dB, at broadside and at a beam 0.35 columns off a
    sector centre at 0.5 deg elevation; same broadside gain within 0.05 dB."""
    cylinder, conformal, resource = _cylinders()
    # The file is the graph's cylinder (benchmarks/make_cppar10_elements.py is up to date).
    mine, theirs = resource[0], cylinder.element_layout()
    np.testing.assert_allclose(mine.column_position, theirs.column_position, atol=1e-6)
    np.testing.assert_allclose(mine.stack_m, theirs.stack_m, atol=1e-6)
    np.testing.assert_array_equal(mine.channel, theirs.channel)
    d = np.arange(-4.0, 4.0001, 0.02)
    off_centre = (413 + 77.5 + 0.35) * 360.0 / 624  # 283.18 deg
    assert cylinder.sector(off_centre)[1] == pytest.approx(0.35)
    for steer in (cylinder.broadside(), (off_centre, 0.5)):
        for az, el in (
            (steer[0] + d, np.full_like(d, steer[1])),
            (np.full_like(d, steer[0]), steer[1] + d),
        ):
            a = cylinder.fields_at(*steer, az, el)
            b = conformal.fields_at(*steer, az, el, 0, resource)
            for port in ("h_co", "v_co"):
                ref, got = db(getattr(a, port)), db(getattr(b, port))
                lobes = ref > ref.max() - 45.0  # main lobe and first sidelobes (-30 dB design)
                assert np.max(np.abs(got - ref)[lobes]) < 0.05, (steer, port)
    assert conformal.broadside() == pytest.approx(cylinder.broadside())


@pytest.mark.slow
def test_cylinder_from_its_element_file_has_the_cylinders_gain_and_solid_angles():
    """The full-sphere directivity and the broadside two-way solid angles of the file
    description against antenna.cylindrical's (its own sphere integral): within 0.05 dB and
    0.1 %."""
    cylinder, conformal, resource = _cylinders(support_deg=10.0, grid_step_deg=0.05)
    assert conformal.pattern_gain_db(resource) == pytest.approx(cylinder.gain_db, abs=0.05)
    for pol, omega in cylinder.omega.items():
        assert conformal.omega[pol] == pytest.approx(omega, rel=1e-3)


@pytest.mark.parametrize("n", [16, 32])
@pytest.mark.parametrize("theta", [0.0, 30.0, 45.0])
def test_uniform_line_half_power_width_is_0886_lambda_over_n_d_cos_theta(n, theta):
    """A uniform line of isotropic elements half a wavelength apart, steered ``theta`` off
    broadside: the 3-dB width of its azimuth cut (measures.half_power_beamwidth_deg) against
    0.886 lambda / (N d cos theta) within 2 %."""
    line = LinearArray(
        name="line",
        elements=n,
        spacing_m=LAMBDA / 2,
        taper="uniform",
        element="isotropic",
        face_azimuth_deg=0.0,
        support_deg=1.0,
        grid_step_deg=0.5,
    )
    d = np.arange(-15.0, 15.0, 0.002)
    f = line.fields_at(theta, 0.0, theta + d, np.zeros_like(d))
    width = half_power_beamwidth_deg(d, np.abs(f.h_co) ** 2)
    theory = np.rad2deg(0.886 * LAMBDA / (n * LAMBDA / 2 * np.cos(np.deg2rad(theta))))
    assert width == pytest.approx(theory, rel=0.02)


# ---- the lattices against the planar array ----------------------------------------------------

PLANAR = dict(n_x=12, n_y=10, face_azimuth_deg=285.0, support_deg=2.0, grid_step_deg=0.25)


@pytest.mark.parametrize(
    "electronics",
    [
        {},
        dict(amplitude_error_db=0.5, phase_error_deg=5.0, failure_probability=0.1, errors_seed=3),
        dict(phase_bits=3, attenuator_bits=4),
        dict(phase_bits=4, randomize_quantization=True),
        dict(subarray_x=2, subarray_y=5, steering="subarray"),
        dict(element="crossed_dipole", cross_pol_db=-30.0, face_tilt_deg=10.0, taper="kaiser"),
    ],
    ids=["ideal", "errors-failures", "quantised", "randomised", "subarrays", "dipole-tilt"],
)
def test_rectangular_lattice_is_the_planar_array(electronics):
    """antenna.lattice on a rectangular lattice against antenna.planar (separable array
    factors, its own weights code) with the same parameters and the same channel draws: every
    field component equal within 1e-9 of the peak on a cut 40 deg wide, steered 15 deg off
    broadside and 5 deg up."""
    lattice_params = {k: v for k, v in electronics.items() if k != "steering"}
    planar = PlanarPatchArray(name="antenna", **PLANAR, **electronics)
    lattice = LatticeArray(name="antenna", **PLANAR, **lattice_params)
    az = 300.0 + np.linspace(-20.0, 20.0, 401)
    el = np.full_like(az, 5.0)
    a, b = planar.fields_at(300.0, 5.0, az, el, 7), lattice.fields_at(300.0, 5.0, az, el, 7)
    for x, y in zip(a, b, strict=True):
        assert np.max(np.abs(np.asarray(x) - np.asarray(y))) < 1e-9


def test_planar_array_describes_its_elements_as_the_lattice_lays_them_out():
    """antenna.planar's element_layout (its positions, normals and channels, not used by its
    separable sums) is antenna.lattice's layout for the same parameters, per element and
    per subarray."""
    for extra in ({}, dict(steering="subarray", subarray_x=3, subarray_y=5)):
        planar = PlanarPatchArray(name="p", face_tilt_deg=12.0, **PLANAR, **extra)
        lattice_params = {k: v for k, v in extra.items() if k != "steering"}
        mine = LatticeArray(name="l", face_tilt_deg=12.0, **PLANAR, **lattice_params).layout
        theirs = planar.element_layout()
        for field in ("column_position", "normal", "axis", "stack_m", "channel"):
            np.testing.assert_allclose(getattr(theirs, field), getattr(mine, field), atol=1e-12)


def test_projected_taylor_taper_on_a_face_is_the_sampled_design_taper():
    """On a flat face the columns' projected positions are uniformly spaced, and the
    continuous Taylor taper there (``taper_axis: projected``, fitted to scipy's window) is
    scipy's own samples (``columns``): the fields agree within 1e-9 at a beam 20 deg off."""
    common = dict(n_x=20, n_y=4, face_azimuth_deg=0.0, support_deg=1.0, grid_step_deg=0.5)
    a = LatticeArray(name="a", taper_axis="columns", **common)
    b = LatticeArray(name="a", taper_axis="projected", **common)
    az = np.linspace(-10.0, 50.0, 301)
    fa, fb = a.fields_at(20.0, 0.0, az, 0 * az), b.fields_at(20.0, 0.0, az, 0 * az)
    assert np.max(np.abs(fa.h_co - fb.h_co)) < 1e-9


def test_triangular_lattice_moves_the_elevation_grating_lobe_out():
    """Columns a lambda apart vertically (dy = lambda) steered 30 deg up: a rectangular
    lattice's reciprocal lattice puts a grating lobe at sin(el) = 0.5 - 1 (-30 deg) at full
    height; the triangular lattice (odd columns raised dy / 2) has reciprocal vectors
    (1 / (2 dx), 1 / dy) and (0, 2 / dy), so none in the vertical plane within the visible
    range: that lobe is gone (below -20 dB)."""
    common = dict(
        n_x=16, n_y=8, spacing_x_m=LAMBDA / 2, spacing_y_m=LAMBDA, element="isotropic",
        taper="uniform", face_azimuth_deg=0.0, support_deg=1.0, grid_step_deg=0.5,
    )  # fmt: skip
    el = np.linspace(-60.0, 60.0, 1201)
    grating = np.abs(el + 30.0) < 0.5
    for lattice, expect in (("rectangular", (-0.5, 0.5)), ("triangular", (-80.0, -20.0))):
        array = LatticeArray(name="a", lattice=lattice, **common)
        f = array.fields_at(0.0, 30.0, np.zeros_like(el), el)
        p = db(f.h_co) - db(f.h_co).max()
        assert expect[0] < p[grating].max() < expect[1], lattice


# ---- the gain, the layouts, the file ------------------------------------------------------


def test_gain_of_an_omni_ring_is_the_brute_force_sphere_integral():
    """pattern_gain_db of 24 omnidirectional elements on a ring (a smooth pattern, no ground
    plane) against 4 pi / the integral of its broadside beam's power on a 1 deg grid (the
    trapezoid rule on both axes, independent code): within 0.01 dB."""
    ring = RingArray(
        name="r", elements=24, radius_m=0.2, element="omni", taper="uniform",
        active_sector_deg=360.0, support_deg=1.0, grid_step_deg=0.5,
    )  # fmt: skip
    az = np.arange(0.0, 360.0, 1.0)
    el = np.arange(-90.0, 90.0001, 1.0)
    f = ring.fields_at(285.0, 0.0, az[None, :], el[:, None])
    rows = (np.abs(f.h_co) ** 2).sum(axis=1) * np.deg2rad(1.0)
    integral = np.trapezoid(rows * np.cos(np.deg2rad(el)), np.deg2rad(el))
    assert ring.pattern_gain_db() == pytest.approx(10 * np.log10(4 * np.pi / integral), abs=0.01)


@pytest.mark.slow
@pytest.mark.parametrize(
    "array",
    [
        LatticeArray(name="a", n_x=5, n_y=4, lattice="triangular", face_azimuth_deg=30.0),
        RingArray(name="r", elements=24, radius_m=0.2, element="crossed_dipole", arc_deg=180.0),
    ],
    ids=["lattice", "arc"],
)
def test_gain_is_the_brute_force_sphere_integral(array):
    """pattern_gain_db (integral about the stack axis, splined) against 4 pi / the integral of
    the broadside beam's H power (co + cross) on a 0.5 deg azimuth-elevation grid: 0.02 dB."""
    az0, el0 = array.broadside()
    step = 0.5
    az = np.arange(0.0, 360.0, step)
    el = np.arange(-90.0, 90.0001, step)
    f = array.fields_at(az0, el0, az[None, :], el[:, None])
    power = np.abs(f.h_co) ** 2 + np.abs(f.h_cross) ** 2
    rows = power.sum(axis=1) * np.deg2rad(step)  # periodic in azimuth
    integral = np.trapezoid(rows * np.cos(np.deg2rad(el)), np.deg2rad(el))
    assert array.pattern_gain_db() == pytest.approx(10 * np.log10(4 * np.pi / integral), abs=0.02)


def test_element_file_round_trip_groups_columns(tmp_path):
    """A cylindrical arc written element by element is read back as the same columns and
    stack; an irregular set (one element moved) as one element a column, with the same field
    up to the move; each element file problem is one line naming the file and line."""
    layout = ring_layout(12, 1.0, 90.0, 40.0, stack=4, spacing_z_m=0.05)
    path = tmp_path / "arc.csv"
    write_element_file(path, layout, comment="a test arc")
    back = layout_from_elements(*read_element_file(path))
    np.testing.assert_allclose(back.column_position, layout.column_position, atol=1e-6)
    np.testing.assert_allclose(back.stack_m, layout.stack_m, atol=1e-6)
    np.testing.assert_array_equal(back.channel, layout.channel)
    positions, normals, channels = read_element_file(path)
    positions[0, 2] += 0.01
    loose = layout_from_elements(positions, normals, channels)
    assert loose.stack_m.size == 1 and loose.column_position.shape[0] == 48
    text = path.read_text().splitlines()
    cases = {
        "x_m,y_m,z_m\n1,2,3\n": "line 1: missing column(s) normal_x, normal_y, normal_z",
        f"{text[1]}\n0,1,0,0,1,0,0\n0,1,0,0,two,0,1\n": "line 3: not a number",
        f"{text[1]}\n0,1,0,0,2,0,0\n": "line 2: the normal has length 2",
        f"{text[1]}\n0,1,0,0,1,0,0.5\n": "line 2: channel must be a whole number",
        f"{text[1]}\n0,1,0,0,1,0,0\n0,1,0,0,1,0,1\n": "two elements stand at the same position",
    }
    for content, message in cases.items():
        bad = tmp_path / "bad.csv"
        bad.write_text(content)
        with pytest.raises(ValueError, match=re.escape(message)) as info:
            layout_from_elements(*read_element_file(bad), source=f"element file {bad}")
        assert str(bad) in str(info.value) and "\n" not in str(info.value)


def test_single_elements_are_tapered_across_and_up_as_the_lattices_columns():
    """A lattice given as single elements (one element a column, as an irregular file is
    read: tapered by the ranks of the elements' positions across the beam and up) against
    antenna.lattice computing it by columns and stack: fields within 1e-9, with channel
    errors drawn per element alike."""
    from pasim_blocks.antennas.layouts import Layout

    params = dict(n_x=6, n_y=4, face_azimuth_deg=200.0)
    errors = dict(phase_error_deg=8.0, failure_probability=0.1, support_deg=1.0, grid_step_deg=0.5)
    lattice = LatticeArray(name="antenna", **params, **errors)
    grouped = lattice.layout
    single = Layout(
        column_position=grouped.positions().reshape(-1, 3),
        normal=np.repeat(grouped.normal, grouped.stack_m.size, axis=0),
        axis=grouped.axis,
        stack_m=np.zeros(1),
        channel=grouped.channel.reshape(-1, 1),
    )
    conformal = ElementFileArray(
        name="antenna", path=ELEMENTS_CSV, active_sector_deg=360.0, broadside_azimuth_deg=200.0,
        **errors,
    )  # fmt: skip
    az, el = np.meshgrid(np.linspace(170, 230, 61), np.linspace(-10, 50, 31))
    a = lattice.fields_at(210.0, 25.0, az, el, 1)
    b = conformal.fields_at(210.0, 25.0, az, el, 1, (single, None))
    for x, y in zip(a, b, strict=True):
        assert np.max(np.abs(np.asarray(x) - np.asarray(y))) < 1e-9


def test_triangular_layout_raises_every_other_column():
    layout = lattice_layout(4, 3, 0.05, 0.06, 0.0, 0.0, "triangular")
    z = layout.positions()[..., 2]
    np.testing.assert_allclose(z[1] - z[0], 0.03)
    np.testing.assert_allclose(z[2], z[0])


# ---- every electronics path on every geometry -------------------------------------------------


def _small_arrays(tmp_path):
    arc = ring_layout(16, 0.5, 120.0, 285.0, stack=4, spacing_z_m=0.0524)
    path = tmp_path / "arc.csv"
    write_element_file(path, arc)
    return {
        "linear": (LinearArray, dict(elements=12, subarray=2)),
        "ring": (RingArray, dict(elements=48, radius_m=0.4, elements_per_column=4)),
        "lattice": (LatticeArray, dict(n_x=6, n_y=4, lattice="triangular", subarray_y=2)),
        "file": (ElementFileArray, dict(path=str(path), broadside_azimuth_deg=285.0)),
    }


@pytest.mark.parametrize("geometry", ["linear", "ring", "lattice", "file"])
def test_each_geometry_runs_every_electronics_path(geometry, tmp_path):
    """Each geometry with errors, failures, quantised shifters and attenuators and per-beam or
    boresight calibration: the chunk's pattern Dataset holds both ports, the errors lower the
    beam's peak below the ideal copy's (gain lost), the same seed draws the same array and
    another seed another, and boresight calibration gives every beam the broadside solid
    angle."""
    cls, params = _small_arrays(tmp_path)[geometry]
    common = dict(support_deg=4.0, grid_step_deg=0.5, **params)
    impaired = dict(
        amplitude_error_db=1.0, phase_error_deg=10.0, failure_probability=0.2,
        phase_bits=3, attenuator_bits=3,
    )  # fmt: skip
    beams = xr.Dataset(
        {"azimuth": ("beam", [283.0, 287.0]), "elevation": ("beam", [0.5, 1.0])},
        coords={"beam": [0, 1]},
    )
    for calibration in ("per_beam", "boresight"):
        block = cls(name="antenna", calibration=calibration, **common, **impaired)
        resource = block.load()
        out = block.process({"beams": beams}, Chunk(beams=np.arange(2), seed=3, resource=resource))
        ds = out["pattern"]
        assert ds["power"].shape == (2, 2, block.d_el.size, block.d_az.size)
        assert ds.attrs["calibration"] == calibration
        if calibration == "boresight":
            sr = ds["calibration_solid_angle_sr"].values
            np.testing.assert_array_equal(sr[0], sr[1])
    ideal = block.ideal_copy()
    assert ideal is not None and ideal.channel.ideal
    az0, el0 = block.broadside()
    here = np.array([az0]), np.array([el0])

    def peak(array, seed):
        return complex(array.fields_at(az0, el0, *here, seed, resource).h_co[0])

    # Failed modules lose gain: the alive elements' in-phase sum is less than all of them.
    failing = cls(name="antenna", failure_probability=0.5, **common)
    assert abs(peak(failing, 3)) < abs(peak(ideal, 3)) == pytest.approx(1.0)
    again = cls(name="antenna", **common, **impaired)
    assert peak(again, 3) == peak(block, 3) and peak(again, 4) != pytest.approx(peak(block, 3))


# ---- the graphs, the command and the study's tools -------------------------------------------


def test_bad_configurations_are_named_at_validation(tmp_path, capsys):
    """A taper over a sector wider than 180 deg, a subarray that does not divide, an arc a
    beam cannot reach, and a missing element file: each named by ``pasim validate``."""
    text = (GRAPHS / "ring_array.yaml").read_text()
    cases = {
        "active_sector_deg: 90.0": ("active_sector_deg: 200.0", "a taylor taper needs a sector"),
        "elements: 384,": ("elements: 384, subarray: 5,", "5 does not divide the 384"),
        "active_sector_deg: 90.0, calibration: per_beam, centre_azimuth_deg: 285.0": (
            "active_sector_deg: 10.0, calibration: per_beam, centre_azimuth_deg: 330.0, "
            "arc_deg: 30.0",
            "have no column of the 30 deg arc",
        ),
    }
    bad = tmp_path / "bad.yaml"
    for old, (new, message) in cases.items():
        assert old in text
        bad.write_text(text.replace(old, new))
        code, err = pasim(capsys, "validate", str(bad))
        assert code == 2 and message in err, err
        assert "Traceback" not in err
    text = (GRAPHS / "conformal_file.yaml").read_text()
    bad.write_text(text.replace("graphs/cppar10_elements.csv", str(tmp_path / "missing.csv")))
    code, err = pasim(capsys, "validate", str(bad))
    assert code == 2 and "missing.csv" in err and "Traceback" not in err
    # A file that exists but holds a bad line: `pasim pattern` names the file and the line.
    elements = tmp_path / "bad.csv"
    elements.write_text("x_m,y_m,z_m,normal_x,normal_y,normal_z\n0,1,0,0,1,0\n0.05,1,0,0,two,0\n")
    bad.write_text(text.replace("graphs/cppar10_elements.csv", str(elements)))
    code, err = pasim(capsys, "pattern", str(bad))
    assert code == 2 and "Traceback" not in err
    assert f"element file {elements}, line 3: not a number" in err and len(err.splitlines()) == 1


def test_pattern_command_measures_the_ring_graph(capsys):
    """``pasim pattern --json`` on graphs/ring_array.yaml: the azimuth beamwidth against the
    aperture estimate 1.2 lambda / D of a -30 dB Taylor taper over the sector's chord
    (within 25 %), the first sidelobe near the -30 dB design, and the ring's gain."""
    code, out, err = pasim_out(
        capsys, "pattern", str(GRAPHS / "ring_array.yaml"), "--json", "--span", "10"
    )
    assert code == 0, err
    figures = json.loads(out)
    assert figures["type"] == "antenna.ring"
    chord = 2 * 3.2 * np.sin(np.deg2rad(45.0))  # 90 deg sector of a 3.2 m ring
    assert 0.8 < figures["beamwidth_az_deg"] / np.rad2deg(1.2 * LAMBDA / chord) < 1.25
    assert -34.0 < figures["first_sidelobe_db"] < -27.0
    assert 30.0 < figures["gain_db"] < 45.0


@pytest.mark.slow
def test_study_tools_and_pattern_command_measure_the_new_graphs(capsys):
    """The study's pattern tools on graphs/ring_array.yaml (H/V ratio per beam: the same on
    every commutated beam; peak sidelobe near the -30 dB design) and ``pasim pattern`` on
    graphs/conformal_file.yaml: the 10 m CPPAR's Table 6 beamwidth (1.1 deg, within 0.1) and
    a first sidelobe at or below -30 dB, as antenna.cylindrical gives them
    (tests/antennas/test_pattern_command.py)."""
    from pasim_blocks.study.patterns import antenna, hv_ratio_db, peak_sidelobes

    block, resource = antenna(load(GRAPHS / "ring_array.yaml"))
    ratio = hv_ratio_db(block, resource, np.array([280.0, 290.0]), 0.5, 0)
    assert np.all(np.isfinite(ratio)) and abs(ratio[0] - ratio[1]) < 0.01
    lobes = peak_sidelobes(block, resource, np.array([285.0]), 0.5, 0)
    assert len(lobes) == 1 and -33.0 < lobes[0] < -27.0
    graph = str(GRAPHS / "conformal_file.yaml")
    code, out, err = pasim_out(capsys, "pattern", graph, "--json", "--span", "10")
    assert code == 0, err
    figures = json.loads(out)
    assert figures["beamwidth_az_deg"] == pytest.approx(1.1, abs=0.1)
    assert figures["first_sidelobe_db"] <= -30.0
