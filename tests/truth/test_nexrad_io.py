"""Tests for pasim_blocks.truth.nexrad_io: reading a merged, cleaned truth sweep from Level-II.

Most tests use the real KLBB volume from ``shared/data`` beside the repository (or the file
named by the environment variable PASIM_TRUTH_FILE) and are skipped when it is absent; the
tests of the cut selection and merge logic run on synthetic data everywhere.
"""

from __future__ import annotations

import gzip
import hashlib
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from pasim_blocks.truth import level2
from pasim_blocks.truth.gridding import (
    _nearest_circular,
    assemble,
    drop_duplicate_radials,
    sector_order,
)
from pasim_blocks.truth.level2 import (
    FIELD_NAMES,
    CutData,
    Moment,
    _Cut,
    _read_moments,
    choose_cuts,
    scan_volume,
    time_order,
)
from pasim_blocks.truth.level2_file import load_volume_bytes
from pasim_blocks.truth.nexrad_io import TruthSweep, read_truth_sweep

_SHARED_FILE = Path(__file__).parents[2].parent / "shared" / "data" / "KLBB20160601_150025_V06"
# sha256 of KLBB20160601_150025_V06, from the data's README.
_KLBB_SHA256 = "b5b8639605a0c88be1ed1f1941333304e559fcf31f8ca3c98aac1520c9896914"

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
    plain = sector_order(az, (240.0, 330.0), 0.0)
    wider = sector_order(az, (240.0, 330.0), 1.0)
    assert wider.size - plain.size == 4  # two 0.5 deg radials on each side
    assert az[wider[0]] >= 239.0 and az[wider[-1]] <= 331.0
    np.testing.assert_array_equal(sector_order(az, (0.0, 360.0), 0.0), np.arange(az.size))
    np.testing.assert_array_equal(sector_order(az, None, 0.0), np.arange(az.size))


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
    plain = load_volume_bytes(truth_file)
    assert plain[:4] == b"AR2V" and len(plain) > 5 * truth_file.stat().st_size
    wrapped = tmp_path / (truth_file.name + ".gz")
    wrapped.write_bytes(gzip.compress(truth_file.read_bytes(), compresslevel=1))
    assert load_volume_bytes(wrapped) == plain
    uncompressed = tmp_path / (truth_file.name + ".raw")
    uncompressed.write_bytes(plain)
    assert load_volume_bytes(uncompressed) == plain
    reference = _fields_digest(read_truth_sweep(truth_file, 0.5, (240.0, 250.0)))
    for variant in (wrapped, uncompressed):
        assert _fields_digest(read_truth_sweep(variant, 0.5, (240.0, 250.0))) == reference


def test_truncated_volume_says_so_and_where(truth_file: Path, tmp_path: Path) -> None:
    """A cut-off download that ends inside a wanted cut is refused as truncated, naming the
    cut and the last radial read (not reported as a missing sector)."""
    # One megabyte of this volume ends inside the 0.5 deg Doppler cut.
    cut_short = tmp_path / "truncated_V06"
    cut_short.write_bytes(truth_file.read_bytes()[:1_000_000])
    with pytest.raises(
        ValueError,
        match=r"is truncated: the file ends at byte 1,000,000, "
        r"inside the 0\.\d+ deg cut after its radial \d+ \(azimuth",
    ):
        read_truth_sweep(cut_short)
    # Cut before the first radial.
    cut_short.write_bytes(truth_file.read_bytes()[:30_000])
    with pytest.raises(ValueError, match="is truncated: the file ends at byte 30,000, before"):
        read_truth_sweep(cut_short)
    # Cut after the cuts a 0.5 deg sweep needs: nothing of what is read is missing.
    cut_short.write_bytes(truth_file.read_bytes()[:3_000_000])
    sweep = read_truth_sweep(cut_short)
    assert np.count_nonzero(np.isfinite(sweep.fields["VRADH"])) > 0


# ---------------------------------------------------------- real volume: what is read


def _fields_digest(sweep: TruthSweep) -> str:
    h = hashlib.sha256()
    for values in (sweep.azimuth_deg, sweep.range_m, *(sweep.fields[n] for n in FIELD_NAMES)):
        h.update(np.ascontiguousarray(values).tobytes())
    return h.hexdigest()


@pytest.mark.parametrize(
    ("elevation_deg", "sector_deg", "margin_deg", "digest"),
    [
        (0.5, None, 0.0, "785525c5829e77f584594d32daa40802322ac506e14f80912ff5ae0e5448ee6a"),
        (
            0.5,
            (240.0, 330.0),
            10.0,
            "e5df99c965f504e91d16811bb61297d5d765a4a59a7f11df7c392934ff62120b",
        ),
        (2.4, None, 0.0, "9f839f0a88c0062bba7d4884d1a060d7463c9b5d5b822eef01b63a58f7d60299"),
    ],
)
def test_same_bits_as_the_whole_volume_xradar_reader(
    truth_file: Path, elevation_deg, sector_deg, margin_deg, digest
) -> None:
    """Digests of what the previous reader returned: it decompressed and parsed the whole
    volume with xradar, then merged; this one stops after the cuts and decodes itself."""
    if hashlib.sha256(truth_file.read_bytes()).hexdigest() != _KLBB_SHA256:
        pytest.skip("digests are of KLBB20160601_150025_V06")
    sweep = read_truth_sweep(truth_file, elevation_deg, sector_deg, margin_deg)
    assert _fields_digest(sweep) == digest


def test_codes_and_geometry_match_xradar(truth_file: Path) -> None:
    """xradar decodes the same records independently: same codes, azimuths and ranges."""
    xradar = pytest.importorskip("xradar")
    cuts = scan_volume(truth_file, 0.5).cuts
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tree = xradar.io.open_nexradlevel2_datatree(
            str(truth_file), sweep=[0, 1], first_dim="time", mask_and_scale=False
        )
    for cut in cuts[:2]:
        theirs = tree[f"sweep_{cut.index}"].to_dataset()
        radials = time_order(cut.radials)
        ours = _read_moments(radials, radials[0], FIELD_NAMES)
        assert set(ours) == set(theirs.data_vars) & set(FIELD_NAMES)
        az = np.array([r.azimuth_deg for r in radials])
        np.testing.assert_array_equal(az, theirs["azimuth"].to_numpy())
        for name, moment in ours.items():
            codes = theirs[name].to_numpy()
            n = moment.codes.shape[1]
            np.testing.assert_array_equal(moment.codes, codes[:, :n], err_msg=name)
            assert not codes[:, n:].any(), name  # xradar pads shorter moments with code 0
            gates = moment.first_gate_m + moment.gate_step_m * np.arange(n)
            np.testing.assert_array_equal(gates, theirs["range"].to_numpy()[:n])
            assert moment.scale_factor == theirs[name].attrs["scale_factor"], name
            assert moment.add_offset == theirs[name].attrs["add_offset"], name


def _count_records(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    taken: list[int] = []
    records = level2.records

    def counting(raw, path, cut=None):
        for record in records(raw, path, cut):
            taken.append(len(record))
            yield record

    monkeypatch.setattr(level2, "records", counting)
    return taken


def test_only_the_records_up_to_the_wanted_cuts_are_decompressed(
    truth_file: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    taken = _count_records(monkeypatch)
    read_truth_sweep(truth_file, 19.5)  # the last cut: everything
    everything = len(taken)
    assert everything > 40
    taken.clear()
    read_truth_sweep(truth_file, 0.5)  # the first two cuts of eleven
    assert 5 <= len(taken) <= everything // 3


def test_a_sector_decodes_only_its_radials(
    truth_file: Path, truth: TruthSweep, monkeypatch: pytest.MonkeyPatch
) -> None:
    decoded: list[int] = []
    read_moments = level2._read_moments

    def counting(radials, reference, names):
        decoded.append(len(radials))
        return read_moments(radials, reference, names)

    monkeypatch.setattr(level2, "_read_moments", counting)
    sweep = read_truth_sweep(truth_file, 0.5, sector_deg=(240.0, 330.0), margin_deg=5.0)
    # Surveillance radials in 235..335 deg, then the Doppler radials paired with them.
    assert len(decoded) == 2
    assert decoded[0] == sweep.azimuth_deg.size and 196 <= decoded[0] <= 204
    assert decoded[1] <= decoded[0]
    rows = np.searchsorted(truth.azimuth_deg, sweep.azimuth_deg)
    np.testing.assert_array_equal(truth.azimuth_deg[rows], sweep.azimuth_deg)
    for name, values in sweep.fields.items():
        np.testing.assert_array_equal(values, truth.fields[name][rows], err_msg=name)


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
    surveillance, doppler = choose_cuts(cuts, 0.5, Path("x"))
    assert (surveillance.index, doppler.index) == (0, 1)


def test_choose_legacy_single_pol_split_pair() -> None:
    # Pre-dual-pol split cut: reflectivity alone, then reflectivity + velocity + width.
    cuts = [_cut(0, 0.5, "DBZH"), _cut(1, 0.5, "DBZH", "VRADH", "WRADH"), _cut(2, 1.5, "DBZH")]
    surveillance, doppler = choose_cuts(cuts, 0.5, Path("x"))
    assert (surveillance.index, doppler.index) == (0, 1)


def test_choose_non_split_cut_alone() -> None:
    cuts = [_cut(0, 0.5, "DBZH"), _cut(1, 0.5, "DBZH", "VRADH"), _cut(2, 2.4, "DBZH", "VRADH")]
    surveillance, doppler = choose_cuts(cuts, 2.5, Path("x"))
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
    surveillance, doppler = choose_cuts(cuts, 0.5, Path("x"))
    assert (surveillance.index, doppler.index) == (0, 1)


def test_choose_rejects_far_elevation() -> None:
    cuts = [_cut(0, 0.5, "DBZH"), _cut(1, 1.5, "DBZH")]
    with pytest.raises(ValueError, match=r"vol\.ar2.*0\.50, 1\.50"):
        choose_cuts(cuts, 3.0, Path("vol.ar2"))


# ------------------------------------------------------------ synthetic: merge of cuts

# Level-II (scale, offset): value = (code - offset) / scale.
_SCALE = {"DBZH": (2.0, 66.0), "VRADH": (2.0, 129.0), "WRADH": (2.0, 129.0)}


def _synthetic_cut(
    azimuth, moments: dict[str, tuple[np.ndarray, float, float]]
) -> tuple[CutData, list[np.ndarray]]:
    """A cut of undecoded codes (``moments[name] = (codes, first gate m, gate step m)``), and
    the list the rows the merge reads from it are appended to."""
    read_rows: list[np.ndarray] = []

    def read(rows, names):
        read_rows.append(np.asarray(rows))
        out = {}
        for name in names:
            if name in moments:
                codes, first, step = moments[name]
                scale, offset = _SCALE[name]
                out[name] = Moment(codes[rows], first, step, 1.0 / scale, -offset / scale)
        return out

    return CutData(np.asarray(azimuth, dtype=np.float64), read), read_rows


def _velocity_codes(v) -> np.ndarray:
    return np.round(129 + 2 * np.asarray(v, dtype=np.float64)).astype(np.uint8)


def test_assemble_legacy_single_pol_split_cut() -> None:
    az_s = np.array([359.8, 0.3, 0.8, 1.3, 2.7])  # time order, crossing north
    dbz = np.full((5, 6), 106, dtype=np.uint8)  # 20 dBZ everywhere ...
    dbz[2, 1] = 0  # ... except one gate below threshold
    surv, _ = _synthetic_cut(az_s, {"DBZH": (dbz, 2125.0, 250.0)})

    az_d = np.array([0.25, 359.9, 0.85, 1.4, 2.0])  # 2.7 has no partner within 0.25 deg
    # Doppler radial i, gate g carries 10 i + g m/s (code = 129 + 2 v), so rows are traceable.
    vel = _velocity_codes(10 * np.arange(5)[:, None] + np.arange(4)[None, :])
    vel[:, 0] = 1  # range folded
    width = np.full((5, 4), 131, dtype=np.uint8)  # 1 m/s
    width[:, 3] = 120  # a negative width, physically impossible
    dopp, dopp_rows = _synthetic_cut(
        az_d, {"VRADH": (vel, 2125.0, 250.0), "WRADH": (width, 2125.0, 250.0)}
    )

    azimuth, range_m, fields = assemble(
        surv, dopp, radial_width_deg=0.5, sector_deg=None, margin_deg=0.0
    )
    np.testing.assert_allclose(azimuth, [0.3, 0.8, 1.3, 2.7, 359.8])
    np.testing.assert_allclose(range_m, 2125.0 + 250.0 * np.arange(6))
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
    # Only the Doppler radials paired with a surveillance radial were read (not 2.0 deg).
    np.testing.assert_array_equal(dopp_rows[0], [0, 1, 2, 3])


def test_assemble_finer_doppler_gates_are_averaged_by_range() -> None:
    """Message 1 geometry: 1 km reflectivity gates from 0 m, 250 m Doppler gates from -375 m."""
    dbz = np.full((1, 3), 106, dtype=np.uint8)  # gates centred 0, 1000, 2000 m
    surv, _ = _synthetic_cut([10.0], {"DBZH": (dbz, 0.0, 1000.0)})
    nyquist = 28.0
    v = np.full(10, np.nan)  # centres -375, -125, ..., 1875 m: four per gate, two in gate 2
    v[0:4] = [1.0, 2.0, 4.0, 5.0]  # gate 0: mean 3
    v[4:8] = [27.0, -27.0, np.nan, np.nan]  # gate 1: folded at +-28, i.e. 27 and 29: mean 28
    v[9] = 28.5  # gate 2: one valid gate just beyond the Nyquist velocity, kept as it is
    vel = np.where(np.isnan(v), 0, _velocity_codes(np.nan_to_num(v))).astype(np.uint8)[None, :]
    width = np.where(np.isnan(v), 0, 131).astype(np.uint8)[None, :]  # 1 m/s where measured
    dopp, _ = _synthetic_cut(
        [10.2], {"VRADH": (vel, -375.0, 250.0), "WRADH": (width, -375.0, 250.0)}
    )

    _, range_m, fields = assemble(
        surv,
        dopp,
        radial_width_deg=1.0,
        sector_deg=None,
        margin_deg=0.0,
        nyquist_velocity_ms=nyquist,
    )
    np.testing.assert_allclose(range_m, [0.0, 1000.0, 2000.0])
    np.testing.assert_allclose(fields["VRADH"][0], [3.0, 28.0, 28.5], atol=1e-5)
    # Width of the summed spectra: sqrt(mean w^2 + mean (v - mean v)^2).
    spread0 = np.mean((np.array([1.0, 2.0, 4.0, 5.0]) - 3.0) ** 2)
    np.testing.assert_allclose(
        fields["WRADH"][0], np.sqrt([1.0 + spread0, 1.0 + 1.0, 1.0]), rtol=1e-6
    )
    # With no Nyquist velocity known the mean is arithmetic: 27 and -27 average to 0.
    _, _, plain = assemble(surv, dopp, radial_width_deg=1.0, sector_deg=None, margin_deg=0.0)
    np.testing.assert_allclose(plain["VRADH"][0], [3.0, 0.0, 28.5], atol=1e-5)


def test_assemble_wrapping_sector_order() -> None:
    az = np.array([5.0, 355.0, 0.5, 180.0, 359.5, 9.5])
    codes = np.full((6, 2), 100, dtype=np.uint8)
    surv, surv_rows = _synthetic_cut(az, {"DBZH": (codes, 2125.0, 250.0)})
    azimuth, _, _ = assemble(
        surv, None, radial_width_deg=0.5, sector_deg=(355.0, 10.0), margin_deg=0.0
    )
    np.testing.assert_allclose(azimuth, [355.0, 359.5, 0.5, 5.0, 9.5])
    # Only the radials in the sector were read, in sector order.
    np.testing.assert_array_equal(surv_rows[0], [1, 4, 2, 0, 5])


def test_overlapping_radials_are_dropped() -> None:
    # A 721-radial sweep: the last radial repeats the first azimuth.
    az = np.append(np.arange(0.25, 360.0, 0.5), 0.27)
    keep = drop_duplicate_radials(az, 0.5)
    assert keep.size == 720 and az.size - 1 not in keep
    np.testing.assert_array_equal(drop_duplicate_radials(az[:-1], 0.5), np.arange(720))


def test_equal_azimuths_pair_with_the_earlier_radial() -> None:
    source = np.array([10.0, 20.0, 20.0, 359.9, 0.1, 0.1])
    target = np.array([19.9, 20.1, 20.0, 0.05, 5.0])
    np.testing.assert_array_equal(_nearest_circular(target, source, 0.5), [1, 1, 1, 4, -1])


def test_record_cache_answers_by_content(truth_file: Path, tmp_path: Path) -> None:
    """The per-process cache of decompressed records (level2_file.decompressed_record) gives
    what bzip2 gives (the independent computation: bz2.decompress of each record), and a file
    changed in place is decoded afresh, never answered from the cache by its path."""
    import bz2

    from pasim_blocks.truth import level2_file

    raw = level2_file.open_volume(truth_file)
    first = list(level2_file.records(raw, truth_file))
    again = list(level2_file.records(raw, truth_file))
    assert again == first
    pos, expected = level2_file.VOLUME_HEADER_BYTES, []
    while pos + 4 <= len(raw) and len(expected) < 3:
        size = abs(int.from_bytes(raw[pos : pos + 4], "big", signed=True))
        expected.append(bz2.decompress(raw[pos + 4 : pos + 4 + size]))
        pos += 4 + size
    assert first[:3] == expected
    # The same path, the second record's bytes damaged: an error, not the cached record.
    damaged = bytearray(raw)
    start = level2_file.VOLUME_HEADER_BYTES
    second = start + 4 + abs(int.from_bytes(raw[start : start + 4], "big", signed=True))
    damaged[second + 40 : second + 48] = bytes(8)
    with pytest.raises(ValueError, match="corrupt bzip2 record"):
        list(level2_file.records(bytes(damaged), truth_file))
