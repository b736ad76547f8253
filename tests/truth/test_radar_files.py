"""Truth from radar files in other formats, read through xradar's backends.

What each test compares against:

* the field mapping: the aliases and standard names as the formats' documentation and
  xradar's model spell them (hand-written cases);
* a CfRadial 1 file written by xradar from the Level-II truth sweep (the project's own
  reader): read back through the xradar path, every field equals the Level-II sweep's (an
  independent path through a format round trip), and a run at the ``expected`` level gives
  the same scores to the last digit;
* the sample files of ``tests/fixtures/truth`` (cut from the public files, see its README):
  ODIM (DBZH, TH, VRADH) runs single polarisation and without width and says so; UF RHIs are
  refused by name (the truth block reads PPIs by elevation); a Radx CfRadial 1 file and a
  Rainbow volume read; a file no backend reads names each format tried;
* IRIS runs and scores all six moments: the sample of ``tests/fixtures/truth``, the first
  40 rays (0-40 deg) and 300 gates (to 90 km) of the public file, cut by
  ``make_iris_sample.py`` there.
"""

from __future__ import annotations

import json

import numpy as np
import xarray as xr

from ..conftest import FIXTURES, GRAPHS, pasim_out

GENERIC = str(GRAPHS / "generic_radar.yaml")


def sample(name: str):
    """A sample truth file of tests/fixtures/truth (in the repository: never skipped)."""
    return FIXTURES / "truth" / name


def test_field_names_map_onto_the_six_moments():
    from pasim_blocks.truth.radar_files import field_map

    names = ["reflectivity", "differential_reflectivity", "cross_correlation_ratio"]
    names += ["UPHIDP", "velocity", "spectrum_width", "KDP"]
    assert field_map(names, {}) == {
        "DBZH": "reflectivity",
        "ZDR": "differential_reflectivity",
        "RHOHV": "cross_correlation_ratio",
        "PHIDP": "UPHIDP",
        "VRADH": "velocity",
        "WRADH": "spectrum_width",
    }
    # DBZH before TH (total power); PHIDP before UPHIDP; any case
    assert field_map(["TH", "dbzh", "UPHIDP", "PHIDP"], {}) == {"DBZH": "dbzh", "PHIDP": "PHIDP"}
    # by standard name when no name is known
    assert field_map(["Z1"], {"Z1": "radar_equivalent_reflectivity_factor_h"}) == {"DBZH": "Z1"}


def cfradial_from_level2(tmp_path):
    """The bundled 0.5 deg truth sweep (own Level-II reader), written by xradar as CfRadial 1."""
    import xradar
    from pasim_blocks import DEFAULT_SCENE
    from pasim_blocks.truth.nexrad_io import read_truth_sweep

    sweep = read_truth_sweep(DEFAULT_SCENE, 0.5, sector_deg=(270.0, 300.0), margin_deg=5.0)
    n = sweep.azimuth_deg.size
    ds = xr.Dataset(
        {
            name: (("azimuth", "range"), values, {"units": "x"})
            for name, values in sweep.fields.items()
        },
        coords={
            "azimuth": ("azimuth", sweep.azimuth_deg),
            "range": ("range", sweep.range_m.astype(np.float32)),
            "elevation": ("azimuth", np.full(n, sweep.elevation_deg)),
            "time": (
                "azimuth",
                np.datetime64("2016-06-01T15:00:25") + np.arange(n).astype("m8[ms]"),
            ),
            "latitude": sweep.site["latitude"],
            "longitude": sweep.site["longitude"],
            "altitude": sweep.site["altitude"],
        },
    )
    ds["sweep_mode"] = "azimuth_surveillance"
    ds["sweep_number"] = 0
    ds["sweep_fixed_angle"] = 0.5
    ds["nyquist_velocity"] = ("azimuth", np.full(n, sweep.nyquist_velocity_ms))
    root = xr.Dataset(
        {
            "time_coverage_start": "2016-06-01T15:00:25Z",
            "time_coverage_end": "2016-06-01T15:00:45Z",
            "volume_number": 0,
            "platform_type": "fixed",
            "instrument_type": "radar",
        },
        coords={k: sweep.site[k] for k in ("latitude", "longitude", "altitude")},
        attrs={"instrument_name": "KLBB", "Conventions": "Cf/Radial", "history": "pasim test"},
    )
    tree = xr.DataTree.from_dict({"/": root, "/sweep_0": ds})
    out = tmp_path / "klbb_cfradial1.nc"
    xradar.io.to_cfradial1(tree, out)
    return sweep, out


def test_a_cfradial_file_reads_back_as_the_level2_sweep(tmp_path):
    from pasim_blocks.truth.radar_files import read_radar_sweep

    sweep, path = cfradial_from_level2(tmp_path)
    again = read_radar_sweep(path, 0.5, sector_deg=(270.0, 300.0), margin_deg=5.0)
    np.testing.assert_allclose(again.azimuth_deg, sweep.azimuth_deg, atol=1e-4)
    np.testing.assert_allclose(again.range_m, sweep.range_m, atol=0.01)
    assert sorted(again.fields) == sorted(sweep.fields)
    for name, values in sweep.fields.items():
        np.testing.assert_allclose(again.fields[name], values, rtol=1e-6, err_msg=name)


def test_a_cfradial_file_scores_as_the_level2_file_at_the_expected_level(tmp_path, capsys):
    _, path = cfradial_from_level2(tmp_path)
    args = ["--sector", "280:290", "--set", "weather.method=expected"]
    scores = {}
    for name, truth in (("level2", []), ("cfradial", ["--truth", str(path)])):
        out = tmp_path / f"{name}.zarr"
        code, _, err = pasim_out(capsys, "run", GENERIC, *args, *truth, "--out", str(out))
        assert code == 0, err
        code, text, err = pasim_out(capsys, "score", str(out), "--json")
        scores[name] = json.loads(text)
    assert scores["cfradial"] == scores["level2"]


def test_iris_sigmet_runs_and_scores_all_six_moments(tmp_path, capsys):
    path = sample("SUR210819000227_40rays_300gates.RAWKPJV")
    out = tmp_path / "iris.zarr"
    code, _, err = pasim_out(
        capsys, "run", GENERIC, "--truth", str(path), "--sector", "10:20", "--out", str(out)
    )
    assert code == 0, err
    assert "single polarisation" not in err
    code, text, err = pasim_out(capsys, "score", str(out), "--json")
    scores = json.loads(text)
    for moment in ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"):
        assert scores[moment]["count"] > 100, moment


def test_odim_runs_single_polarisation_and_says_so(tmp_path, capsys):
    path = sample("T_PAZD63_C_LFPW_20230420065331.h5")
    out = tmp_path / "odim.zarr"
    code, _, err = pasim_out(
        capsys, "run", GENERIC, "--truth", str(path), "--sector", "0:90", "--out", str(out)
    )
    assert code == 0, err
    assert err.count("single polarisation") == 1 and "no WRADH" in err, err
    scores = json.loads(pasim_out(capsys, "score", str(out), "--json")[1])
    # Scored against the truth: the two moments it holds; WRADH is listed as having none.
    assert sorted(k for k, v in scores.items() if not v.get("no_truth")) == ["DBZH", "VRADH"]
    assert scores["WRADH"]["no_truth"] is True and scores["WRADH"]["count"] == 0


def test_uf_rhis_are_refused_by_name(tmp_path, capsys):
    path = sample("MC3E_NPOL_2011_0524_2356_hid_300gates.uf.gz")
    code, _, err = pasim_out(
        capsys, "run", GENERIC, "--truth", str(path), "--out", str(tmp_path / "s")
    )
    assert code == 2 and "holds only RHI sweeps" in err and "Traceback" not in err, err


def test_a_file_no_backend_reads_names_the_formats_tried(tmp_path, capsys):
    path = tmp_path / "noise.bin"
    path.write_bytes(np.random.default_rng(0).bytes(5000))
    code, _, err = pasim_out(
        capsys, "run", GENERIC, "--truth", str(path), "--out", str(tmp_path / "s")
    )
    assert code == 2, err
    assert "no radar-file reader opens it" in err and "IRIS/Sigmet" in err and "UF" in err, err


def test_a_radx_cfradial1_file_reads_with_its_character_array_time():
    from pasim_blocks.truth.radar_files import read_radar_sweep

    sweep = read_radar_sweep(sample("houkasacrcfrM1.a1.20210922.150006_300gates.nc"), 1.0)
    assert sweep.site["time_coverage_start"] == "2021-09-22T15:00:06Z"
    assert sweep.site["instrument_name"] == "KaSACR-1"
    assert sweep.range_m.size == 300 and abs(sweep.range_m[0] - 403.07) < 0.01
    assert {"DBZH", "VRADH"} <= set(sweep.fields) and sweep.azimuth_deg.size == 61


def test_a_rainbow_volume_reads():
    from pasim_blocks.truth.radar_files import read_radar_sweep

    sweep = read_radar_sweep(sample("2013051000000600dBZ.vol"), 0.5)
    assert abs(sweep.elevation_deg - 0.6) < 0.05
    assert sweep.azimuth_deg.size == 360 and sweep.range_m.size == 400
    assert sweep.site["time_coverage_start"] == "2013-05-10T00:00:06Z"
    assert np.isfinite(sweep.fields["DBZH"]).sum() > 1000
