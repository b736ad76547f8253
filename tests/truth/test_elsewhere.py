"""The radar elsewhere (truth.elsewhere): gates placed in three dimensions from another site
and the truth volume read there; velocity refused from a single radar's volume, projected
exactly from a gridded truth's wind (truth.grid with u, v, w).

Every geometry here is checked against an independent computation: pyproj's great circles
on the same sphere (a = 6371 km) and Doviak and Zrnic's 4/3-earth equations (1993, eq. 2.28)
written out again below, inverted by the law of cosines (the block inverts by atan2 on the
equivalent earth).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.truth.elsewhere import ElsewhereTruth
from pasim_blocks.truth.grid import GriddedTruth
from pasim_blocks.truth.sites import seen_from

from pasim_graph import Chunk
from pasim_graph.graphfile import read

from ..conftest import GRAPHS, pasim_out

pyproj = pytest.importorskip("pyproj")
NO_BEAMS = np.arange(0)
A = 6_371_000.0
KA = 4.0 / 3.0 * A
GEOD = pyproj.Geod(a=A, b=A)


def dz_height(r, el_deg):
    """Doviak and Zrnic eq. 2.28b."""
    return np.sqrt(r**2 + KA**2 + 2 * r * KA * np.sin(np.deg2rad(el_deg))) - KA


def dz_ground(r, el_deg):
    """Doviak and Zrnic eq. 2.28c."""
    return KA * np.arcsin(r * np.cos(np.deg2rad(el_deg)) / (KA + dz_height(r, el_deg)))


def by_hand(site, other, r, az, el):
    """A gate at (r, az, el) from ``site`` seen from ``other`` (lat, lon, alt): its height
    above ``site``, and range, azimuth, elevation from ``other``; pyproj for the great circles,
    the law of cosines on the equivalent earth for the inverse."""
    h, s = dz_height(r, el), dz_ground(r, el)
    lon, lat, _ = GEOD.fwd(site[1], site[0], az, s)
    fwd, _, s2 = GEOD.inv(other[1], other[0], lon, lat)
    h2 = site[2] + h - other[2]
    r2 = np.sqrt((KA + h2) ** 2 + KA**2 - 2 * KA * (KA + h2) * np.cos(s2 / KA))
    el2 = np.rad2deg(np.arcsin(((KA + h2) ** 2 - r2**2 - KA**2) / (2 * r2 * KA)))
    return h, r2, np.mod(fwd, 360.0), el2


def test_five_gates_of_the_elsewhere_graph_within_10_m_of_pyproj(truth_dataset):
    """graphs/generic_radar_elsewhere.yaml's radar 40 km east of KLBB: five gates of its scan
    (sector edges and middle, 10 to 140 km) have the height and the place in KLBB's volume
    (range, cross-range, height) that pyproj and eq. 2.28 give, within 10 m."""
    spec = read(GRAPHS / "generic_radar_elsewhere.yaml")
    view, scan = spec.blocks["view"].params, spec.blocks["scan"].params
    klbb = tuple(float(truth_dataset.attrs[k]) for k in ("latitude", "longitude", "altitude"))
    block = ElsewhereTruth(name="view", **view)
    site, other = block.site(truth_dataset)
    lon, lat, _ = GEOD.fwd(klbb[1], klbb[0], 90.0, float(view["east_m"]))
    moved = GEOD.inv(lon, lat, site[1], site[0])[2]
    assert moved < 10.0 and other == klbb
    el = float(scan["elevation_deg"])
    gates = [(scan["azimuth_start_deg"], 10e3), (262.0, 50e3), (285.0, 90e3), (300.0, 120e3)]
    gates.append((scan["azimuth_stop_deg"], 140e3))
    for az, r in gates:
        seen = seen_from(site, other, np.array([r]), np.array([az]), el)
        h, r2, az2, el2 = by_hand(site, other, r, az, el)
        assert abs(seen.height_m[0, 0] - h) < 10.0
        assert abs(seen.range_m[0, 0] - r2) < 10.0
        cross = r2 * np.deg2rad((seen.azimuth_deg[0, 0] - az2 + 180) % 360 - 180)
        assert abs(cross) < 10.0
        up = seen.range_m[0, 0] * np.sin(np.deg2rad(seen.elevation_deg[0, 0]))
        assert abs(up - r2 * np.sin(np.deg2rad(el2))) < 10.0


def storm(la, lo, zz):
    """An analytic storm: 50 dBZ at 35.15 N 100.05 W, 2 km up, 10 dBZ far away."""
    d2 = ((la - 35.15) / 0.06) ** 2 + ((lo + 100.05) / 0.07) ** 2 + ((zz - 2e3) / 1.5e3) ** 2
    return 10.0 + 40.0 * np.exp(-0.5 * d2)


def geographic_grid(path, wind=None):
    lat = np.arange(34.8, 35.5 + 1e-9, 0.0025)
    lon = np.arange(-100.6, -99.6 + 1e-9, 0.0025)
    z = np.arange(0.0, 8e3 + 1, 200.0)
    values = storm(lat[None, :, None], lon[None, None, :], z[:, None, None]).astype(np.float32)
    ds = xr.Dataset(
        {"DBZH": (("height", "lat", "lon"), values)},
        coords={"height": z, "lat": lat, "lon": lon},
    )
    for name, v in (wind or {}).items():
        ds[name] = (("height", "lat", "lon"), np.full(values.shape, v, np.float32))
    ds.to_netcdf(path)
    return path


def grid_truth(path, **more):
    """The grid's truth from a radar at 35 N 100.25 W, 300 m up (finer with ``more``)."""
    params = {
        "latitude": 35.0,
        "longitude": -100.25,
        "altitude_m": 300.0,
        "elevation_deg": 1.0,
        "elevation_min_deg": 0.5,
        "elevation_max_deg": 3.0,
        "elevation_step_deg": 0.5,
        "elevation_margin_deg": 0.5,
        "radial_width_deg": 1.0,
        "gate_width_m": 500.0,
        "max_range_m": 40e3,
        "azimuth_start_deg": 10.0,
        "azimuth_stop_deg": 90.0,
        "margin_deg": 0.0,
    }
    block = GriddedTruth(name="truth", path=str(path), **{**params, **more})
    return block.process({}, Chunk(beams=NO_BEAMS, resource=block.load()))["truth"]


def test_the_storm_seen_from_the_east_is_where_pyproj_puts_it(tmp_path):
    """An analytic storm in a geographic grid, its truth taken by a radar at 35 N 100.25 W,
    then seen by a radar 20 km east and 500 m higher at 1.5 deg: every gate with echo reads
    the analytic field at the place pyproj and eq. 2.28 give for it within 0.5 dB (the
    truth's 0.25 deg radials, 100 m gates and 0.25 deg sweeps, read at the nearest), and the
    strongest gate lies on the bearing pyproj gives from the new site to the storm's centre,
    within 1.5 deg."""
    fine = {"elevation_step_deg": 0.25, "radial_width_deg": 0.25, "gate_width_m": 100.0}
    fine |= {"elevation_min_deg": 1.0, "elevation_max_deg": 2.5}
    truth = grid_truth(geographic_grid(tmp_path / "storm.nc"), **fine)
    block = ElsewhereTruth(
        name="view",
        east_m=20e3,
        altitude_m=800.0,
        elevation_deg=1.5,
        elevation_min_deg=1.5,
        elevation_max_deg=1.5,
        elevation_margin_deg=0.0,
        radial_width_deg=0.5,
        gate_width_m=250.0,
        max_range_m=25e3,
        azimuth_start_deg=330.0,
        azimuth_stop_deg=20.0,
        margin_deg=0.0,
    )
    view = block.process({"truth_in": truth}, Chunk(beams=NO_BEAMS))["truth"]
    site = (view.attrs["latitude"], view.attrs["longitude"], view.attrs["altitude"])
    lon0, lat0, _ = GEOD.fwd(-100.25, 35.0, 90.0, 20e3)
    assert GEOD.inv(lon0, lat0, site[1], site[0])[2] < 1.0
    r, az = view["range"].values, view["azimuth"].values
    rr, aa = np.meshgrid(r, az)
    h, s = dz_height(rr, 1.5), dz_ground(rr, 1.5)
    lon, lat, _ = GEOD.fwd(np.full(rr.shape, site[1]), np.full(rr.shape, site[0]), aa, s)
    want = storm(lat, lon, site[2] + h)
    got = view["DBZH"].values
    echo = np.isfinite(got)
    assert echo.sum() > 0.8 * got.size
    assert np.abs(got[echo] - want[echo]).max() < 0.5
    row, _ = np.unravel_index(np.nanargmax(got), got.shape)
    bearing = GEOD.inv(site[1], site[0], -100.05, 35.15)[0] % 360.0
    assert abs((az[row] - bearing + 180) % 360 - 180) < 1.5


def test_velocity_of_a_single_radar_truth_is_refused_in_one_line(tmp_path):
    """A truth whose radial velocity is one radar's measurement (here a grid's VRADH without a
    wind): refused with one line naming why; with velocity: omit, no VRADH."""
    path = tmp_path / "storm.nc"
    geographic_grid(path)
    ds = xr.open_dataset(path).load()
    ds["VRADH"] = (ds["DBZH"].dims, np.full(ds["DBZH"].shape, 5.0, np.float32))
    ds.to_netcdf(tmp_path / "vel.nc")
    truth = grid_truth(tmp_path / "vel.nc", max_range_m=10e3)
    assert "volume_VRADH" in truth
    block = ElsewhereTruth(name="view", east_m=5e3, max_range_m=5e3)
    with pytest.raises(ValueError) as err:
        block.process({"truth_in": truth}, Chunk(beams=NO_BEAMS))
    message = str(err.value)
    assert "\n" not in message
    assert "radial velocity refused" in message and "cannot be projected" in message
    omit = ElsewhereTruth(name="view", east_m=5e3, max_range_m=5e3, velocity="omit")
    with pytest.warns(Warning, match="no radial velocity"):
        view = omit.process({"truth_in": truth}, Chunk(beams=NO_BEAMS))["truth"]
    assert "VRADH" not in view and "volume_VRADH" not in view


def test_a_gridded_wind_projects_exactly_on_the_new_beams(tmp_path):
    """A uniform wind (u, v, w) = (12, -5, 0.8) m/s in the grid: the grid radar's VRADH and
    the radar 20 km east's are the wind projected on each ray where it crosses the gate (its
    azimuth there from pyproj's back azimuth, its elevation el + s / (k a)), within 1 mm/s."""
    u, v, w = 12.0, -5.0, 0.8
    truth = grid_truth(geographic_grid(tmp_path / "wind.nc", {"u": u, "v": v, "w": w}))
    assert "volume_eastward_wind" in truth

    def projected(site, r, az, el):
        rr, aa = np.meshgrid(r, az)
        s = dz_ground(rr, el)
        lon, lat, _ = GEOD.fwd(np.full(rr.shape, site[1]), np.full(rr.shape, site[0]), aa, s)
        back = GEOD.inv(lon, lat, np.full(rr.shape, site[1]), np.full(rr.shape, site[0]))[0]
        a = np.deg2rad(np.where(s > 0, back + 180.0, aa))
        e = np.deg2rad(el + np.rad2deg(s / KA))
        return (u * np.sin(a) + v * np.cos(a)) * np.cos(e) + w * np.sin(e)

    got = truth["VRADH"].values
    want = projected((35.0, -100.25), truth["range"].values, truth["azimuth"].values, 1.0)
    assert np.nanmax(np.abs(got - want)) < 1e-3
    block = ElsewhereTruth(
        name="view",
        east_m=20e3,
        altitude_m=800.0,
        elevation_deg=1.0,
        elevation_min_deg=1.0,
        elevation_max_deg=1.0,
        elevation_margin_deg=0.0,
        max_range_m=25e3,
        azimuth_start_deg=330.0,
        azimuth_stop_deg=20.0,
        margin_deg=0.0,
    )
    view = block.process({"truth_in": truth}, Chunk(beams=NO_BEAMS))["truth"]
    site = (view.attrs["latitude"], view.attrs["longitude"])
    got = view["VRADH"].values
    want = projected(site, view["range"].values, view["azimuth"].values, 1.0)
    echo = np.isfinite(got)
    assert echo.sum() > 0.8 * got.size
    assert np.abs(got[echo] - want[echo]).max() < 1e-3


def test_a_single_sweep_truth_is_refused(truth_dataset):
    """The radar elsewhere needs the truth in three dimensions: one sweep is refused, in one
    line naming what to set."""
    with pytest.raises(ValueError, match=r"needs a volume truth .*sweeps: volume"):
        ElsewhereTruth(name="view").process({"truth_in": truth_dataset}, Chunk(beams=NO_BEAMS))


@pytest.mark.slow
def test_the_elsewhere_graph_refuses_velocity_in_one_line(tmp_path, capsys):
    """pasim run graphs/generic_radar_elsewhere.yaml with velocity: refuse (KLBB's velocity
    is one radar's): exit 2, one line naming why, no traceback, no store (reads the volume:
    slow)."""
    out = tmp_path / "x.zarr"
    graph = str(GRAPHS / "generic_radar_elsewhere.yaml")
    code, _, err = pasim_out(
        capsys,
        "run",
        graph,
        "--set",
        "view.velocity=refuse",
        "--sector",
        "280:282",
        "--out",
        str(out),
    )
    assert code == 2 and "Traceback" not in err, err
    (line,) = [x for x in err.splitlines() if "error" in x]
    assert "radial velocity refused" in line and "cannot be projected" in line
    assert not (out / "sweep_0").exists()


@pytest.mark.slow
def test_a_gridded_wind_seen_from_elsewhere_end_to_end(tmp_path):
    """(Slow: a whole run, about 10 s.) The generic radar 20 km east of a gridded truth's
    radar, its truth a uniform wind (12, -5, 0.8) m/s in the analytic storm: the run
    (expected level, two beams) scores velocity, and its estimate is the truth's projected
    wind within 0.1 m/s on every scored gate (the truth's projection is checked against the
    wind by hand above)."""
    from pasim_graph.executor import LocalExecutor, RunOptions
    from pasim_graph.graph import load

    path = geographic_grid(tmp_path / "wind.nc", {"u": 12.0, "v": -5.0, "w": 0.8})
    text = (GRAPHS / "generic_radar_elsewhere.yaml").read_text()
    text = text.replace(
        "truth:    {type: truth.nexrad, params: {elevation_deg: 0.5, elevation_max_deg: 2.5, "
        "elevation_min_deg: 0.5, sweeps: volume}}",
        f"truth:    {{type: truth.grid, params: {{path: {path}, latitude: 35.0, longitude: "
        "-100.25, altitude_m: 300.0, elevation_min_deg: 0.5, elevation_max_deg: 3.0, "
        "elevation_step_deg: 0.25, radial_width_deg: 0.5, gate_width_m: 250.0, "
        "max_range_m: 40000.0, azimuth_start_deg: 0.0, azimuth_stop_deg: 90.0, "
        "margin_deg: 0.0}}",
    )
    text = text.replace("velocity: omit", "velocity: refuse, max_range_m: 25000.0")
    graph = tmp_path / "g.yaml"
    graph.write_text(text)
    sets = {
        "view.altitude_m": 800.0,
        "view.east_m": 20e3,
        "view.elevation_min_deg": 1.5,
        "view.elevation_max_deg": 1.5,
        "view.elevation_deg": 1.5,
        "view.azimuth_start_deg": 350.0,
        "view.azimuth_stop_deg": 10.0,
        "scan.azimuth_start_deg": 355.0,
        "scan.azimuth_stop_deg": 357.0,
        "scan.elevation_deg": 1.5,
        "weather.method": "expected",
    }
    with pytest.warns(Warning):
        sweep = LocalExecutor(load(graph, sets), RunOptions(seed=1)).run()
    err = sweep["error_VRADH"].values
    assert np.isfinite(err).sum() > 50
    assert np.nanmax(np.abs(err)) < 0.1
