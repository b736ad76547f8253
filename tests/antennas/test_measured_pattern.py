"""Tests of patterns read from files (``blocks/measured_pattern.py``, ``antenna.measured``, the
arrays' ``element: file``).

What each test compares against:

* the file format: a pattern written and read back is the same to 1e-9; malformed files are
  refused with the file, the line and what was expected;
* a whole antenna: the generic radar's pencil beam tabulated on a 0.05 deg grid (with a
  -30 dB four-lobe cross-polar component) read by ``antenna.measured`` gives back the
  analytic pattern of ``antenna.pencil`` (linear interpolation error below 2e-3 of the peak),
  the file's peak gain and its cross-polar peak, and `pasim pattern` measures its 1 deg /
  -32 dB;
* an element: the cavity-model patch tabulated in its face frame and used as
  ``element: file`` gives the same array pattern as ``element: patch`` (within 1e-3).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.antennas.aperture import PencilBeam
from pasim_blocks.antennas.geometry import face_geometry, patch_field
from pasim_blocks.antennas.measured import MeasuredAntenna, TabulatedPattern, read_pattern_file
from pasim_blocks.antennas.pattern_files import write_pattern_file
from pasim_blocks.antennas.pencil import PencilBeamAntenna
from pasim_blocks.antennas.planar import PlanarPatchArray
from pasim_blocks.signals import PATTERN

from pasim_graph import Chunk
from pasim_graph.graphfile import BlockSpec, dumps, read

from ..conftest import GRAPHS, pasim_result


def pencil_file(path, step=0.05, half=6.0, gain_db=45.5, cross_db=-30.0):
    """The generic radar's beam (1 deg, -32 dB) on a regular grid, with a cross-polar
    component of four lobes (sin 2 phi) within the main beam, ``cross_db`` before the
    co-polar fall-off."""
    beam = PencilBeam.design(1.0, -32.0)
    axis = np.arange(-half, half + step / 2, step)
    el, az = np.meshgrid(axis, axis, indexing="ij")
    theta = np.hypot(az, el)
    co = beam.amplitude(theta) * 10 ** (gain_db / 20)
    phi = np.arctan2(el, az)
    cross = 10 ** (cross_db / 20) * np.sin(2 * phi) * theta * np.exp(-theta) * co * np.e
    values = np.stack([co, cross * 1j, co * np.exp(0.3j), -cross])
    table = TabulatedPattern(axis, axis, values.astype(complex))
    write_pattern_file(path, table, comment="generic radar pencil beam\nfor tests")
    return table


def cross_peak_db(table: TabulatedPattern) -> float:
    """The H port's cross-polar peak over its co-polar peak, as written."""
    v = np.abs(table.values) ** 2
    return float(10 * np.log10(v[1].max() / v[0].max()))


def test_round_trip_and_gain(tmp_path) -> None:
    table = pencil_file(tmp_path / "p.csv")
    back = read_pattern_file(tmp_path / "p.csv")
    np.testing.assert_allclose(back.azimuth_deg, table.azimuth_deg)
    np.testing.assert_allclose(back.values, table.values, rtol=1e-8, atol=1e-10)
    assert back.peak_gain_db == pytest.approx(45.5, abs=1e-6)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("azimuth_deg,elevation_deg\n0,0\n", "missing column"),
        (None, "regular grid"),
        ("HEADER\n0,0,x,0,0,0,0,0,0,0\n", "line 3: not a number"),
        ("HEADER\n0,0,0,0\n", "line 3: 4 values"),
    ],
)
def test_bad_files_are_named(tmp_path, text, message) -> None:
    header = (
        "azimuth_deg,elevation_deg,h_co_db,h_co_deg,h_cross_db,h_cross_deg,"
        "v_co_db,v_co_deg,v_cross_db,v_cross_deg"
    )
    if text is None:
        rows = [f"{a},{e},0,0,0,0,0,0,0,0" for a in (0, 1) for e in (0, 1)][:3]
        text = "HEADER\n" + "\n".join(rows) + "\n"
    path = tmp_path / "bad.csv"
    path.write_text("# a comment\n" + text.replace("HEADER", header))
    with pytest.raises(ValueError, match=message) as info:
        read_pattern_file(path)
    assert "bad.csv" in str(info.value)


def beams(elevation=0.5, azimuths=(100.0, 110.0)):
    az = np.asarray(azimuths, float)
    return xr.Dataset(
        coords={"azimuth": ("beam", az), "elevation": ("beam", np.full(az.size, elevation))}
    )


def test_measured_antenna_reproduces_the_pencil(tmp_path) -> None:
    table = pencil_file(tmp_path / "p.csv")
    block = MeasuredAntenna(name="antenna", path=str(tmp_path / "p.csv"), support_deg=5.0)
    out = block.process({"beams": beams()}, Chunk(beams=np.arange(2), resource=block.load()))[
        "pattern"
    ]
    assert PATTERN.schema.check(out) == []
    reference = PencilBeamAntenna(name="p", support_deg=5.0).process(
        {"beams": beams()}, Chunk(beams=np.arange(2))
    )["pattern"]
    # Offsets on the grid: the file is tabulated against the angles from boresight in the
    # antenna frame, which at 0.5 deg elevation are the grid offsets to within 1e-4 deg.
    assert np.max(np.abs(out["power"].values - reference["power"].values)) < 2e-3
    assert out.attrs["gain_db"] == pytest.approx(45.5, abs=1e-6)
    cross = np.abs(out["cross_polar"].values) ** 2
    assert 10 * np.log10(cross.max()) == pytest.approx(cross_peak_db(table), abs=0.2)
    # the V port's phase offset travels with it
    centre = out["co_polar"].values[0, 1, 100, 100]
    assert np.angle(centre) == pytest.approx(0.3, abs=1e-3)


def test_element_file_is_the_patch(tmp_path) -> None:
    """The cavity-model patch tabulated at 0.5 deg over the front hemisphere (face frame),
    used as the element of a 24 x 24 array steered 25 deg: the same fields as the analytic
    element, within 1e-3 (linear interpolation)."""
    size = 0.0524 * 2.8e9 / 299_792_458.0
    az = np.arange(-90.0, 90.001, 0.5)
    el = np.arange(-60.0, 60.001, 0.5)
    f = patch_field(face_geometry(az[None, :], el[:, None], 0.0, 0.0), size)
    shape = (el.size, az.size)
    values = np.stack([np.broadcast_to(np.asarray(c, complex), shape) for c in f])
    write_pattern_file(tmp_path / "patch.csv", TabulatedPattern(az, el, values))
    common = {"n_x": 24, "n_y": 24, "face_azimuth_deg": 0.0, "support_deg": 2.0}
    analytic = PlanarPatchArray(name="a", **common)
    tabulated = PlanarPatchArray(
        name="a", element="file", element_file=str(tmp_path / "patch.csv"), **common
    )
    resource = tabulated.load()
    d_az, d_el = np.meshgrid(np.linspace(-30, 30, 61), np.linspace(-10, 10, 21))
    a = analytic.fields_at(25.0, 0.0, 25.0 + d_az, d_el)
    b = tabulated.fields_at(25.0, 0.0, 25.0 + d_az, d_el, resource=resource)
    for x, y in zip(a, b, strict=True):
        assert np.max(np.abs(np.asarray(x) - np.asarray(y))) < 1e-3
    out = tabulated.process(
        {"beams": beams(0.0, (350.0, 20.0))}, Chunk(beams=np.arange(2), resource=resource)
    )["pattern"]
    assert PATTERN.schema.check(out) == []


def test_pattern_command_on_a_measured_antenna(tmp_path, capsys) -> None:
    table = pencil_file(tmp_path / "p.csv")
    spec = read(GRAPHS / "generic_radar.yaml")
    spec.blocks["antenna"] = BlockSpec("antenna.measured", {"path": str(tmp_path / "p.csv")})
    graph = tmp_path / "measured.yaml"
    graph.write_text(dumps(spec))
    res = pasim_result(capsys, "pattern", str(graph), "--json", "--span", "5")
    assert res.returncode == 0, res.stderr
    figures = json.loads(res.stdout)
    assert figures["beamwidth_az_deg"] == pytest.approx(1.0, abs=0.01)
    assert figures["first_sidelobe_db"] == pytest.approx(-32.0, abs=0.2)
    assert figures["peak_gain_dbi"] == pytest.approx(45.5, abs=0.01)
    assert figures["cross_pol_db"] == pytest.approx(cross_peak_db(table), abs=0.2)
    # element 'file' without a file is a validation problem naming the parameter
    spec.blocks["antenna"] = BlockSpec("antenna.planar", {"element": "file"})
    graph.write_text(dumps(spec))
    res = pasim_result(capsys, "validate", str(graph))
    assert res.returncode == 2 and "element_file" in res.stderr
