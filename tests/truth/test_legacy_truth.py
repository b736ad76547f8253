"""A legacy single-polarisation Level-II file (message 1) as truth.

The file is the one Py-ART's tests carry (``pyart.testing.NEXRAD_ARCHIVE_MSG1_FILE``, KLBB-like
VCP 32 volume from 2003 without a site): reflectivity on 1 km gates from 0 m, velocity and
width on 250 m gates from -375 m, split cuts at 0.5 and 1.5 deg and batch cuts (all three
moments in each radial) above. Py-ART's own reader is the independent decoding.
"""

from __future__ import annotations

import os
import warnings

import numpy as np
import pytest
from pasim_blocks.truth.nexrad import NexradTruth
from pasim_blocks.truth.nexrad_io import read_truth_sweep

from pasim_graph import Chunk, RunNote

os.environ.setdefault("PYART_QUIET", "1")
pyart = pytest.importorskip("pyart")
LEGACY = pyart.testing.NEXRAD_ARCHIVE_MSG1_FILE
NYQUIST_MS = 28.34  # of this file's Doppler cuts


def _pyart(scans: list[int]):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Py-ART's deprecation and interpolation notices
        # Without interpolation each 1 km reflectivity gate is repeated in four 250 m gates.
        return pyart.io.read_nexrad_archive(LEGACY, scans=scans, linear_interp=False)


def _rays(radar, sweep: int) -> slice:
    start = radar.sweep_start_ray_index["data"][sweep]
    return slice(int(start), int(radar.sweep_end_ray_index["data"][sweep]) + 1)


def _nearest_rays(ours: np.ndarray, theirs: np.ndarray) -> np.ndarray:
    """Index of Py-ART's ray nearest each of our azimuths (the first of equal ones)."""
    distance = np.abs((ours[:, None] - theirs[None, :] + 180.0) % 360.0 - 180.0)
    assert distance.min(axis=1).max() <= 0.5  # half of a 1 deg radial
    return np.argmin(distance, axis=1)


def _by_truth_gate(radar, range_m: np.ndarray) -> np.ndarray:
    """Which of our 1 km gates each of Py-ART's 250 m gates lies in (-1: none)."""
    theirs = radar.range["data"].astype(np.float64)
    step = range_m[1] - range_m[0]
    owner = np.floor((theirs - range_m[0] + step / 2) / step).astype(int)
    return np.where((owner >= 0) & (owner < range_m.size), owner, -1)


@pytest.fixture(scope="module")
def truth():
    return read_truth_sweep(LEGACY, 0.5)


@pytest.fixture(scope="module")
def split_pair():
    return _pyart([0, 1])


# ----------------------------------------------------------------- single polarisation


def test_legacy_truth_is_single_polarisation(truth) -> None:
    assert set(truth.fields) == {"DBZH", "VRADH", "WRADH"}
    assert not truth.polarimetric
    assert truth.radial_width_deg == 1.0
    assert truth.gate_width_m == 1000.0
    assert truth.range_m[0] == 0.0 and truth.range_m.size == 460
    assert truth.nyquist_velocity_ms == pytest.approx(NYQUIST_MS)
    assert truth.site["instrument_name"] == ""  # the volume header leaves it blank
    assert truth.site["time_coverage_start"] == "2003-01-01T00:09:21Z"


def test_truth_block_says_single_polarisation_once(truth) -> None:
    block = NexradTruth(name="truth", path=LEGACY)
    with pytest.warns(RunNote) as notes:
        sweep = block.load()
    single = [n for n in notes if n.category is RunNote]
    assert len(single) == 1
    assert str(single[0].message) == (
        "truth example_nexrad_archive_msg1.bz2: no polarimetric fields (ZDR, RHOHV, PHIDP); "
        "running single polarisation (H channel only)"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", RunNote)  # process() must not say it again
        ds = block.process({}, Chunk(beams=np.arange(0), resource=sweep))["truth"]
    assert set(ds.data_vars) == {"DBZH", "VRADH", "WRADH"}
    assert ds.attrs["polarimetric"] == 0 and type(ds.attrs["polarimetric"]) is int


def test_dual_polarisation_truth_says_nothing(truth_dataset) -> None:
    assert {"DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"} <= set(truth_dataset.data_vars)
    assert truth_dataset.attrs["polarimetric"] == 1
    assert type(truth_dataset.attrs["polarimetric"]) is int
    with warnings.catch_warnings():
        warnings.simplefilter("error", RunNote)
        NexradTruth(name="truth", azimuth_start_deg=280.0, azimuth_stop_deg=290.0).load()


def test_truth_attributes_are_zarr_serialisable(truth, tmp_path) -> None:
    import xarray as xr

    block = NexradTruth(name="truth", path=LEGACY)
    ds = block.process({}, Chunk(beams=np.arange(0), resource=truth))["truth"]
    ds.to_zarr(tmp_path / "truth.zarr", consolidated=False)
    assert xr.open_zarr(tmp_path / "truth.zarr", consolidated=False).attrs["polarimetric"] == 0


# ------------------------------------------------------------------ against Py-ART


def test_reflectivity_matches_pyart(truth, split_pair) -> None:
    rays = _rays(split_pair, 0)
    near = _nearest_rays(truth.azimuth_deg, split_pair.azimuth["data"][rays])
    ref = split_pair.fields["reflectivity"]["data"][rays][near]
    # Our gate centred at r is Py-ART's four gates r-375 ... r+375; take r+125.
    theirs = ref[:, np.searchsorted(split_pair.range["data"], truth.range_m + 125.0)]
    valid = ~np.ma.getmaskarray(theirs)
    ours = truth.fields["DBZH"]
    np.testing.assert_array_equal(np.isfinite(ours), valid)
    np.testing.assert_array_equal(ours[valid], theirs.data[valid].astype(np.float32))


def test_velocity_is_pyarts_on_the_same_ranges(truth, split_pair) -> None:
    """Each 1 km gate holds the (circular) mean of Py-ART's 250 m velocities inside it."""
    rays = _rays(split_pair, 1)
    near = _nearest_rays(truth.azimuth_deg, split_pair.azimuth["data"][rays].astype(float))
    vel = split_pair.fields["velocity"]["data"][rays][near]
    width = split_pair.fields["spectrum_width"]["data"][rays][near]
    owner = _by_truth_gate(split_pair, truth.range_m)
    echo = np.isfinite(truth.fields["DBZH"])

    expected_v = np.full(truth.shape, np.nan)
    expected_w = np.full(truth.shape, np.nan)
    singles = np.zeros(truth.shape, dtype=bool)
    for g in range(truth.range_m.size):
        sub_v, sub_w = vel[:, owner == g], width[:, owner == g]
        for i in np.flatnonzero(echo[:, g]):
            v = sub_v[i].compressed().astype(np.float64)
            if v.size == 0:
                continue
            phase = v * np.pi / NYQUIST_MS
            mean = np.arctan2(np.sin(phase).sum(), np.cos(phase).sum()) * NYQUIST_MS / np.pi
            d = (v - mean + NYQUIST_MS) % (2 * NYQUIST_MS) - NYQUIST_MS
            w = sub_w[i].compressed().astype(np.float64)
            expected_v[i, g] = mean
            expected_w[i, g] = np.sqrt(np.mean(w**2) + np.mean(d**2))
            singles[i, g] = v.size == 1

    ours_v, ours_w = truth.fields["VRADH"], truth.fields["WRADH"]
    # The same gates have a velocity: about 2,350 of the 4,093 with echo.
    np.testing.assert_array_equal(np.isfinite(ours_v), np.isfinite(expected_v))
    np.testing.assert_array_equal(np.isfinite(ours_w), np.isfinite(expected_w))
    assert 2_000 < np.count_nonzero(np.isfinite(ours_v)) < 2_700
    # Where one 250 m gate is valid, ours is Py-ART's value at that azimuth and range.
    assert np.count_nonzero(singles) > 300
    np.testing.assert_array_equal(ours_v[singles], _vel_single(vel, owner, singles))
    # Elsewhere the same circular mean, folded the same way.
    fold = np.abs((ours_v - expected_v + NYQUIST_MS) % (2 * NYQUIST_MS) - NYQUIST_MS)
    assert np.nanmax(fold) < 1e-4
    np.testing.assert_allclose(ours_w, expected_w, atol=1e-4)
    assert np.nanmax(np.abs(ours_v)) <= NYQUIST_MS + 0.5


def _vel_single(vel: np.ma.MaskedArray, owner: np.ndarray, singles: np.ndarray) -> np.ndarray:
    """Py-ART's one valid velocity in each of the given truth gates, as float32."""
    out = []
    for i, g in np.argwhere(singles):
        out.append(vel[i, owner == g].compressed()[0])
    return np.asarray(out, dtype=np.float32)


def test_batch_cut_velocity_on_its_own_gates(split_pair) -> None:
    """At 2.5 deg each radial carries 1 km reflectivity and 250 m velocity together."""
    truth = read_truth_sweep(LEGACY, 2.5)
    assert set(truth.fields) == {"DBZH", "VRADH", "WRADH"}
    assert truth.range_m.size == 336
    radar = _pyart([4])
    near = _nearest_rays(truth.azimuth_deg, radar.azimuth["data"].astype(float))
    vel = radar.fields["velocity"]["data"][near]
    owner = _by_truth_gate(radar, truth.range_m)
    count = np.stack(
        [(~np.ma.getmaskarray(vel[:, owner == g])).sum(axis=1) for g in range(truth.shape[1])],
        axis=1,
    )
    expected = (count > 0) & np.isfinite(truth.fields["DBZH"])
    np.testing.assert_array_equal(np.isfinite(truth.fields["VRADH"]), expected)
    singles = (count == 1) & expected
    assert np.count_nonzero(singles) > 100
    np.testing.assert_array_equal(truth.fields["VRADH"][singles], _vel_single(vel, owner, singles))


# --------------------------------------------------------------------------- sectors


@pytest.mark.parametrize(("sector", "margin"), [((240.0, 330.0), 10.0), ((350.0, 20.0), 3.0)])
def test_sector_reads_the_full_sweeps_radials(truth, sector, margin) -> None:
    part = read_truth_sweep(LEGACY, 0.5, sector_deg=sector, margin_deg=margin)
    start = sector[0] - margin
    span = (sector[1] - sector[0]) % 360.0 + 2 * margin
    inside = np.mod(truth.azimuth_deg - start, 360.0) <= span
    expected = np.flatnonzero(inside)
    expected = expected[np.argsort(np.mod(truth.azimuth_deg[expected] - start, 360.0))]
    np.testing.assert_array_equal(part.azimuth_deg, truth.azimuth_deg[expected])
    assert part.azimuth_deg.size == pytest.approx(span, abs=2)  # 1 deg radials
    np.testing.assert_array_equal(part.range_m, truth.range_m)
    for name, values in part.fields.items():
        np.testing.assert_array_equal(values, truth.fields[name][expected], err_msg=name)


def test_truth_block_sector_parameters(truth) -> None:
    block = NexradTruth(
        name="truth", path=LEGACY, azimuth_start_deg=240.0, azimuth_stop_deg=330.0, margin_deg=5.0
    )
    assert block.sector() == (240.0, 330.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RunNote)
        sweep = block.load()
    az = sweep.azimuth_deg
    assert np.all(np.mod(az - 235.0, 360.0) <= 100.0)
    assert az.size == np.count_nonzero(np.mod(truth.azimuth_deg - 235.0, 360.0) <= 100.0)
    full = NexradTruth(name="truth", azimuth_start_deg=0.0, azimuth_stop_deg=360.0)
    assert full.sector() is None and NexradTruth(name="truth").sector() is None
    problems = NexradTruth.check_config({"azimuth_start_deg": 10.0}, set())
    assert problems and "azimuth_stop_deg" in problems[0][1]
    assert NexradTruth.check_config({}, set()) == []
