"""Tests for pasim_blocks.nexrad_io: reading a merged, cleaned truth sweep from Level-II.

Most tests use the real KLBB volume from ``shared/data`` beside the repository (or the file
named by the environment variable PASIM_TRUTH_FILE) and are skipped when it is absent; the
tests of the cut selection and merge logic run on synthetic data everywhere.
"""

from __future__ import annotations

import gzip
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.nexrad_io import (
    FIELD_NAMES,
    TruthSweep,
    _assemble,
    _choose_cuts,
    _Cut,
    _drop_duplicate_radials,
    _load_volume_bytes,
    _sector_order,
    read_truth_sweep,
)

_SHARED_FILE = Path(__file__).parents[1].parent / "shared" / "data" / "KLBB20160601_150025_V06"

# Decoded values of Level-II codes 0 and 1 as xradar 0.12 reports them (see the README of
# the data); PHIDP's are also given wrapped into [0, 360), where an unmasked one would land.
_SENTINELS = {
    "DBZH": (-33.0, -32.5),
    "ZDR": (-8.0, -7.9375),
    "RHOHV": (0.201667, 0.205),
    "PHIDP": (-0.705194, -0.352597, 359.294806, 359.647403),
    "VRADH": (-64.5, -64.0),
    "WRADH": (-64.5, -64.0),
}


def _truth_file() -> Path:
    override = os.environ.get("PASIM_TRUTH_FILE")
    path = Path(override) if override else _SHARED_FILE
    if not path.is_file():
        # The package carries the same public-domain volume as its default scene.
        from pasim_blocks import DEFAULT_SCENE

        path = DEFAULT_SCENE
    if not path.is_file():
        pytest.skip(
            f"real NEXRAD volume not found at {path} (set PASIM_TRUTH_FILE to a copy of "
            "KLBB20160601_150025_V06)"
        )
    return path


def _circular_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs((a - b + 180.0) % 360.0 - 180.0)


@pytest.fixture(scope="module")
def truth_file() -> Path:
    return _truth_file()


@pytest.fixture(scope="module")
def truth(truth_file: Path) -> TruthSweep:
    return read_truth_sweep(truth_file, elevation_deg=0.5)


@pytest.fixture(scope="module")
def sector(truth_file: Path) -> TruthSweep:
    return read_truth_sweep(truth_file, elevation_deg=0.5, sector_deg=(240.0, 330.0))


@pytest.fixture(scope="module")
def pyart_radar(truth_file: Path):
    os.environ.setdefault("PYART_QUIET", "1")
    pyart = pytest.importorskip("pyart")
    with warnings.catch_warnings():
        # Py-ART deprecates its Level-II reader in favour of xradar; here it is the referee.
        warnings.filterwarnings("ignore", message=".*deprecated.*", category=UserWarning)
        return pyart.io.read_nexrad_archive(str(truth_file), scans=[0, 1])


# ----------------------------------------------------------------- real volume: content


def test_all_six_fields_at_half_degree(truth: TruthSweep) -> None:
    assert set(truth.fields) == set(FIELD_NAMES)
    assert truth.polarimetric
    assert truth.shape == (720, 1832)
    for name, values in truth.fields.items():
        assert values.dtype == np.float32, name
        assert values.shape == truth.shape, name
    assert truth.azimuth_deg.dtype == np.float64
    assert truth.range_m.dtype == np.float64
    assert abs(truth.elevation_deg - 0.5) < 0.1
    assert truth.radial_width_deg == 0.5
    assert truth.gate_width_m == 250.0
    assert truth.range_m[0] == pytest.approx(2125.0)
    assert truth.range_m[-1] == pytest.approx(459_875.0)
    # Velocities come from the Doppler cut (short PRT), not the surveillance cut (8.47 m/s).
    assert truth.nyquist_velocity_ms == pytest.approx(22.56)
    assert truth.site["instrument_name"] == "KLBB"
    assert truth.site["latitude"] == pytest.approx(33.654, abs=1e-3)
    assert truth.site["longitude"] == pytest.approx(-101.814, abs=1e-3)
    assert truth.site["altitude"] > 900.0
    assert truth.site["time_coverage_start"].startswith("2016-06-01T15:00")
    assert truth.source == "KLBB20160601_150025_V06"


def test_azimuths_increase_within_one_turn(truth: TruthSweep) -> None:
    az = truth.azimuth_deg
    assert np.all((az >= 0.0) & (az < 360.0))
    assert np.all(np.diff(az) > 0.0)


def test_masks_agree_with_pyart(truth: TruthSweep, pyart_radar) -> None:
    """Py-ART masks codes 0/1 itself: an independent decoding of the same two cuts."""
    starts = pyart_radar.sweep_start_ray_index["data"]
    ends = pyart_radar.sweep_end_ray_index["data"]
    surv = slice(int(starts[0]), int(ends[0]) + 1)
    dopp = slice(int(starts[1]), int(ends[1]) + 1)
    ngates = truth.range_m.size
    np.testing.assert_allclose(pyart_radar.range["data"][:ngates], truth.range_m)

    def pyart_field(name: str, rays: slice, order: np.ndarray) -> np.ma.MaskedArray:
        return pyart_radar.fields[name]["data"][rays][order][:, :ngates]

    # Surveillance cut: the same radials, only in a different order.
    surv_az = pyart_radar.azimuth["data"][surv]
    by_az = np.argsort(surv_az)
    np.testing.assert_allclose(surv_az[by_az], truth.azimuth_deg, atol=1e-3)
    no_echo = np.ma.getmaskarray(pyart_field("reflectivity", surv, by_az))

    tolerance = 1e-4 * truth.azimuth_deg.size * ngates  # a tiny fraction of the gates
    surveillance = {
        "DBZH": "reflectivity",
        "ZDR": "differential_reflectivity",
        "RHOHV": "cross_correlation_ratio",
        "PHIDP": "differential_phase",
    }
    for ours, theirs in surveillance.items():
        reference = pyart_field(theirs, surv, by_az)
        expected = ~np.ma.getmaskarray(reference) & ~no_echo
        got = np.isfinite(truth.fields[ours])
        assert np.count_nonzero(got != expected) <= tolerance, ours
        both = got & expected
        diff = np.abs(truth.fields[ours][both] - reference.data[both])
        if ours == "PHIDP":
            diff = _circular_diff(truth.fields[ours][both], reference.data[both])
        assert diff.max() < 1e-3, ours

    # Doppler cut: pair each of our radials with Py-ART's nearest one, by brute force.
    dopp_az = pyart_radar.azimuth["data"][dopp]
    distance = _circular_diff(truth.azimuth_deg[:, None], dopp_az[None, :])
    nearest = np.argmin(distance, axis=1)
    assert distance[np.arange(nearest.size), nearest].max() <= 0.25
    for ours, theirs in {"VRADH": "velocity", "WRADH": "spectrum_width"}.items():
        reference = pyart_field(theirs, dopp, nearest)
        expected = ~np.ma.getmaskarray(reference) & ~no_echo
        if ours == "WRADH":
            expected &= reference.filled(-1.0) >= 0.0
        got = np.isfinite(truth.fields[ours])
        assert np.count_nonzero(got != expected) <= tolerance, ours
        both = got & expected
        assert np.abs(truth.fields[ours][both] - reference.data[both]).max() < 1e-3, ours


def test_no_sentinel_values_remain(truth: TruthSweep) -> None:
    for name, sentinels in _SENTINELS.items():
        values = truth.fields[name]
        for sentinel in sentinels:
            hits = np.count_nonzero(np.abs(values - sentinel) < 5e-4)
            assert hits == 0, f"{name} still holds {hits} gates at sentinel {sentinel}"
    # The README: about 84 % of the lowest sweep's gates are code 0.
    no_echo = np.mean(np.isnan(truth.fields["DBZH"]))
    assert 0.80 < no_echo < 0.88


def test_values_within_physical_limits(truth: TruthSweep) -> None:
    f = truth.fields
    assert np.nanmin(f["DBZH"]) >= -35.0 and np.nanmax(f["DBZH"]) <= 100.0
    assert np.nanmin(f["ZDR"]) >= -8.0 and np.nanmax(f["ZDR"]) <= 8.0
    assert np.nanmin(f["RHOHV"]) > 0.0
    assert np.nanmin(f["WRADH"]) >= 0.0


def test_rhohv_above_one_survives(truth: TruthSweep) -> None:
    rho = truth.fields["RHOHV"]
    assert 1.0 < np.nanmax(rho) <= 1.1
    assert np.count_nonzero(rho > 1.0) > 1000


def test_phidp_wrapped_into_one_turn(truth: TruthSweep) -> None:
    phi = truth.fields["PHIDP"][np.isfinite(truth.fields["PHIDP"])]
    assert phi.min() >= 0.0
    assert phi.max() < 360.0
    assert np.count_nonzero(phi > 350.0) > 0  # phases wrapping near 360 are kept


def test_no_echo_means_no_moments(truth: TruthSweep) -> None:
    no_echo = np.isnan(truth.fields["DBZH"])
    for name, values in truth.fields.items():
        assert np.all(np.isnan(values[no_echo])), name


def test_doppler_fields_end_at_doppler_range(truth: TruthSweep) -> None:
    beyond = truth.range_m > 300_000.0
    for name in ("VRADH", "WRADH"):
        assert np.all(np.isnan(truth.fields[name][:, beyond])), name
        assert np.count_nonzero(np.isfinite(truth.fields[name][:, ~beyond])) > 100_000, name


def test_velocity_kept_up_to_nyquist(truth: TruthSweep) -> None:
    speed = np.abs(truth.fields["VRADH"])
    assert np.nanmax(speed) <= truth.nyquist_velocity_ms + 0.5
    assert np.nanmax(speed) > 0.9 * truth.nyquist_velocity_ms


# ------------------------------------------------------------------ real volume: sectors


def test_sector_240_330_holds_the_convective_line(sector: TruthSweep, truth: TruthSweep) -> None:
    az = sector.azimuth_deg
    assert 176 <= az.size <= 184
    assert az[0] >= 240.0 and az[-1] <= 330.0
    assert np.all(np.diff(az) > 0.0)
    dbz = sector.fields["DBZH"]
    # The README says about 55,000 gates >= 20 dBZ and 5,800 above 40 dBZ; this volume's
    # surveillance cut gives 50,148 and 6,140 (>= 40) or 5,609 (> 40).
    assert 45_000 <= np.count_nonzero(dbz >= 20.0) <= 60_000
    assert 4_500 <= np.count_nonzero(dbz >= 40.0) <= 7_500
    # Cutting a sector must not change any value.
    rows = np.searchsorted(truth.azimuth_deg, az)
    for name, values in sector.fields.items():
        np.testing.assert_array_equal(values, truth.fields[name][rows], err_msg=name)


def test_wrapping_sector_in_scan_order(truth_file: Path) -> None:
    sweep = read_truth_sweep(truth_file, sector_deg=(350.0, 10.0))
    az = sweep.azimuth_deg
    assert 38 <= az.size <= 42
    assert np.all((az >= 0.0) & (az < 360.0))
    assert az[0] >= 350.0 and az[-1] <= 10.0
    assert np.all(np.diff(np.mod(az - 350.0, 360.0)) > 0.0)
    assert {"DBZH", "VRADH"} <= set(sweep.fields)


def test_margin_and_full_circle_selection(truth: TruthSweep) -> None:
    az = truth.azimuth_deg
    plain = _sector_order(az, (240.0, 330.0), 0.0)
    wider = _sector_order(az, (240.0, 330.0), 1.0)
    assert wider.size - plain.size == 4  # two 0.5 deg radials on each side
    assert az[wider[0]] >= 239.0 and az[wider[-1]] <= 331.0
    np.testing.assert_array_equal(_sector_order(az, (0.0, 360.0), 0.0), np.arange(az.size))
    np.testing.assert_array_equal(_sector_order(az, None, 0.0), np.arange(az.size))


def test_non_split_cut_is_used_alone(truth_file: Path) -> None:
    sweep = read_truth_sweep(truth_file, elevation_deg=2.4)
    assert set(sweep.fields) == set(FIELD_NAMES)
    assert sweep.radial_width_deg == 1.0
    assert 355 <= sweep.azimuth_deg.size <= 362
    assert abs(sweep.elevation_deg - 2.42) < 0.15
    assert np.count_nonzero(np.isfinite(sweep.fields["VRADH"])) > 0


def test_gzip_wrapped_and_uncompressed_volumes_read_the_same(
    truth_file: Path, tmp_path: Path
) -> None:
    plain = _load_volume_bytes(truth_file)
    assert plain[:4] == b"AR2V" and len(plain) > 5 * truth_file.stat().st_size
    wrapped = tmp_path / (truth_file.name + ".gz")
    wrapped.write_bytes(gzip.compress(truth_file.read_bytes(), compresslevel=1))
    assert _load_volume_bytes(wrapped) == plain
    uncompressed = tmp_path / (truth_file.name + ".raw")
    uncompressed.write_bytes(plain)
    assert _load_volume_bytes(uncompressed) == plain


def test_truncated_volume_warns_about_incomplete_cut(truth_file: Path, tmp_path: Path) -> None:
    # One megabyte of this volume ends inside the 0.5 deg Doppler cut.
    cut_short = tmp_path / "truncated_V06"
    cut_short.write_bytes(truth_file.read_bytes()[:1_000_000])
    with pytest.warns(UserWarning, match="incomplete"):
        sweep = read_truth_sweep(cut_short)
    assert set(sweep.fields) == set(FIELD_NAMES)
    assert np.count_nonzero(np.isfinite(sweep.fields["VRADH"])) > 0


# -------------------------------------------------------------------------------- errors


def test_missing_file_names_the_path(tmp_path: Path) -> None:
    missing = tmp_path / "KTLX20130520_200356_V06"
    with pytest.raises(FileNotFoundError, match="KTLX20130520_200356_V06"):
        read_truth_sweep(missing)


@pytest.mark.parametrize("content", [b"", b"not a radar file at all\n" * 10, bytes(range(256))])
def test_not_level2_is_a_value_error(tmp_path: Path, content: bytes) -> None:
    bogus = tmp_path / "bogus_volume.bin"
    bogus.write_bytes(content)
    with pytest.raises(ValueError, match=r"bogus_volume\.bin.*Level-II.*AR2V"):
        read_truth_sweep(bogus)


def test_far_elevation_lists_available_angles(truth_file: Path) -> None:
    with pytest.raises(ValueError, match=r"45\.0.*0\.48, 1\.45, .*19\.51"):
        read_truth_sweep(truth_file, elevation_deg=45.0)


@pytest.mark.parametrize(
    ("sector_deg", "margin_deg"), [((10.0, float("nan")), 0.0), ((0.0, 90.0), -1.0)]
)
def test_bad_sector_arguments(tmp_path: Path, sector_deg, margin_deg) -> None:
    with pytest.raises(ValueError, match=r"sector_deg|margin_deg"):
        read_truth_sweep(tmp_path / "unused", sector_deg=sector_deg, margin_deg=margin_deg)


# ---------------------------------------------------------- synthetic: cut selection


def _cut(index: int, angle: float, *moments: str, width: float = 0.5) -> _Cut:
    return _Cut(index, angle, index + 1, frozenset(moments), 25.0 + index, width)


def test_choose_split_dual_pol_pair() -> None:
    cuts = [
        _cut(0, 0.48, "DBZH", "ZDR", "RHOHV", "PHIDP"),
        _cut(1, 0.48, "DBZH", "VRADH", "WRADH"),
        _cut(2, 1.45, "DBZH", "ZDR", "RHOHV", "PHIDP"),
    ]
    surveillance, doppler = _choose_cuts(cuts, 0.5, Path("x"))
    assert (surveillance.index, doppler.index) == (0, 1)


def test_choose_legacy_single_pol_split_pair() -> None:
    # Pre-dual-pol split cut: reflectivity alone, then reflectivity + velocity + width.
    cuts = [_cut(0, 0.5, "DBZH"), _cut(1, 0.5, "DBZH", "VRADH", "WRADH"), _cut(2, 1.5, "DBZH")]
    surveillance, doppler = _choose_cuts(cuts, 0.5, Path("x"))
    assert (surveillance.index, doppler.index) == (0, 1)


def test_choose_non_split_cut_alone() -> None:
    cuts = [_cut(0, 0.5, "DBZH"), _cut(1, 0.5, "DBZH", "VRADH"), _cut(2, 2.4, "DBZH", "VRADH")]
    surveillance, doppler = _choose_cuts(cuts, 2.5, Path("x"))
    assert surveillance.index == 2 and doppler is None


def test_choose_first_pair_when_elevation_is_revisited() -> None:
    # SAILS volumes scan the lowest elevation again mid-volume.
    full = ("DBZH", "ZDR", "RHOHV", "PHIDP")
    cuts = [
        _cut(0, 0.5, *full),
        _cut(1, 0.5, "DBZH", "VRADH", "WRADH"),
        _cut(2, 0.9, *full),
        _cut(3, 0.5, *full),
        _cut(4, 0.5, "DBZH", "VRADH", "WRADH"),
    ]
    surveillance, doppler = _choose_cuts(cuts, 0.5, Path("x"))
    assert (surveillance.index, doppler.index) == (0, 1)


def test_choose_rejects_far_elevation() -> None:
    cuts = [_cut(0, 0.5, "DBZH"), _cut(1, 1.5, "DBZH")]
    with pytest.raises(ValueError, match=r"vol\.ar2.*0\.50, 1\.50"):
        _choose_cuts(cuts, 3.0, Path("vol.ar2"))


# ------------------------------------------------------------ synthetic: merge of cuts


def _raw_sweep(azimuth, first_gate, ngates, moments: dict[str, np.ndarray]) -> xr.Dataset:
    """An undecoded sweep as xradar returns it with mask_and_scale=False."""
    scale = {"DBZH": (0.5, -33.0), "VRADH": (0.5, -64.5), "WRADH": (0.5, -64.5)}
    variables = {}
    for name, codes in moments.items():
        factor, offset = scale[name]
        attrs = {"scale_factor": factor, "add_offset": offset}
        variables[name] = (("azimuth", "range"), codes.astype(np.uint8), attrs)
    coords = {
        "azimuth": np.asarray(azimuth, dtype=np.float64),
        "range": first_gate + 250.0 * np.arange(ngates, dtype=np.float32),
    }
    return xr.Dataset(variables, coords=coords)


def test_assemble_legacy_single_pol_split_cut() -> None:
    az_s = np.array([359.8, 0.3, 0.8, 1.3, 2.7])  # time order, crossing north
    dbz = np.full((5, 6), 106, dtype=np.uint8)  # 20 dBZ everywhere ...
    dbz[2, 1] = 0  # ... except one gate below threshold
    surv = _raw_sweep(az_s, 2125.0, 6, {"DBZH": dbz})

    az_d = np.array([0.25, 359.9, 0.85, 1.4, 2.0])  # 2.7 has no partner within 0.25 deg
    # Doppler radial i, gate g carries 10 i + g m/s (code = 129 + 2 v), so rows are traceable.
    vel = (129 + 2 * (10 * np.arange(5)[:, None] + np.arange(4)[None, :])).astype(np.uint8)
    vel[:, 0] = 1  # range folded
    width = np.full((5, 4), 131, dtype=np.uint8)  # 1 m/s
    width[:, 3] = 120  # a negative width, physically impossible
    dopp = _raw_sweep(az_d, 2125.0, 4, {"VRADH": vel, "WRADH": width})

    azimuth, range_m, fields = _assemble(
        surv, dopp, radial_width_deg=0.5, sector_deg=None, margin_deg=0.0
    )
    np.testing.assert_allclose(azimuth, [0.3, 0.8, 1.3, 2.7, 359.8])
    assert set(fields) == {"DBZH", "VRADH", "WRADH"}
    sweep = TruthSweep(azimuth, 0.5, range_m, 0.5, 250.0, fields, 25.0, {}, "synthetic")
    assert not sweep.polarimetric

    v = fields["VRADH"]
    assert np.all(np.isnan(v[:, 4:]))  # beyond the Doppler cut's range
    assert np.all(np.isnan(v[:, 0]))  # range-folded code
    assert np.all(np.isnan(v[3]))  # 2.7 deg: no Doppler radial within half a spacing
    # 0.3 pairs with 0.25, 0.8 with 0.85, 1.3 with 1.4 and 359.8 with 359.9 across north.
    np.testing.assert_allclose(v[0, 1:4], [1.0, 2.0, 3.0])
    np.testing.assert_allclose(v[1, 2:4], [22.0, 23.0])
    assert np.isnan(v[1, 1])  # DBZH below threshold there: no moments either
    np.testing.assert_allclose(v[2, 1:4], [31.0, 32.0, 33.0])
    np.testing.assert_allclose(v[4, 1:4], [11.0, 12.0, 13.0])
    assert np.all(np.isnan(fields["WRADH"][:, 3]))
    np.testing.assert_allclose(fields["WRADH"][[0, 2, 4], 1:3], 1.0)
    assert np.isnan(fields["DBZH"][1, 1]) and np.nanmin(fields["DBZH"]) == 20.0


def test_assemble_wrapping_sector_order() -> None:
    az = np.array([5.0, 355.0, 0.5, 180.0, 359.5, 9.5])
    surv = _raw_sweep(az, 2125.0, 2, {"DBZH": np.full((6, 2), 100, dtype=np.uint8)})
    azimuth, _, _ = _assemble(
        surv, None, radial_width_deg=0.5, sector_deg=(355.0, 10.0), margin_deg=0.0
    )
    np.testing.assert_allclose(azimuth, [355.0, 359.5, 0.5, 5.0, 9.5])


def test_overlapping_radials_are_dropped() -> None:
    # A 721-radial sweep: the last radial repeats the first azimuth.
    az = np.append(np.arange(0.25, 360.0, 0.5), 0.27)
    keep = _drop_duplicate_radials(az, 0.5)
    assert keep.size == 720 and az.size - 1 not in keep
    np.testing.assert_array_equal(_drop_duplicate_radials(az[:-1], 0.5), np.arange(720))
