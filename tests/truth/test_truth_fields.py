"""Truth from any file: the names real radars give their fields, the truth block's
``fields`` parameter for the others, and the sweep of every sample file through a graph.

What each test compares against:

* the aliases: the readers' own tables, Py-ART's ``pyart.default_config`` and xradar's
  backends' mappings (each raw name maps to the moment those tables say it holds);
* ``fields``: a file written with the fields renamed, read with ``fields`` naming them,
  equals the same file written under the standard names (an independent path: the names
  are the only difference);
* the sweep (``benchmarks/sweep_truth_files.py``): every fixture file runs through the
  generic radar or the RHI graph, with its moments and their fields reported (the UF RHIs,
  the slowest to read, with -m slow), and a file that cannot be read is refused with one
  line; over ``../shared/data`` and Py-ART's sample files (slow) no file ends in a traceback
  or a block failure.
"""

from __future__ import annotations

import importlib.util
import sys
import warnings

import numpy as np
import pytest

from ..conftest import FIXTURES, GRAPHS, ROOT, pasim_out

GENERIC = str(GRAPHS / "generic_radar.yaml")
ODIM = FIXTURES / "truth" / "T_PAZD63_C_LFPW_20230420065331.h5"


def sweep_module():
    """benchmarks/sweep_truth_files.py, imported by path (benchmarks is not a package)."""
    name = "sweep_truth_files"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(
            name, ROOT / "benchmarks" / "sweep_truth_files.py"
        )
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


# ----------------------------------------------------------------------------- the aliases

#: Py-ART's field names (pyart.config defaults) that hold each of the six moments.
PYART_FIELDS = {
    "DBZH": {"reflectivity", "corrected_reflectivity", "total_power"},
    "ZDR": {"differential_reflectivity", "corrected_differential_reflectivity"},
    "RHOHV": {"cross_correlation_ratio"},
    "PHIDP": {
        "differential_phase",
        "corrected_differential_phase",
        "unfolded_differential_phase",
    },
    "VRADH": {"velocity", "corrected_velocity"},
    "WRADH": {"spectrum_width"},
}
#: ODIM quantities (xradar's names) that hold each moment.
ODIM_NAMES = {
    "DBZH": {"DBZH", "DBTH"},
    "ZDR": {"ZDR"},
    "RHOHV": {"RHOHV"},
    "PHIDP": {"PHIDP", "UPHIDP"},
    "VRADH": {"VRADH"},
    "WRADH": {"WRADH"},
}


def test_each_alias_holds_the_moment_the_readers_say_it_holds():
    """Every alias that Py-ART's or xradar's reader tables also list is mapped there to the
    same moment (the tables are the source the aliases were taken from); the issue's names
    are among them."""
    from pasim_blocks.truth.field_names import ALIASES
    from xradar.io.backends import datamet, rainbow, uf

    # Py-ART's table of names, a module of constants, read without importing Py-ART (whose
    # import takes seconds)
    where = importlib.util.find_spec("pyart")
    assert where is not None and where.submodule_search_locations
    path = f"{next(iter(where.submodule_search_locations))}/default_config.py"
    spec = importlib.util.spec_from_file_location("pyart_default_config", path)
    assert spec is not None and spec.loader is not None
    cfg = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cfg)

    pyart_tables = [
        cfg.sigmet_field_mapping,
        cfg.nexrad_archive_field_mapping,
        cfg.nexrad_cdm_field_mapping,
        cfg.mdv_field_mapping,
        cfg.rsl_field_mapping,
        cfg.chl_field_mapping,
        cfg.gamic_field_mapping,
        cfg.uf_field_mapping,
    ]
    xradar_tables = [uf.uf_mapping, datamet.datamet_mapping, rainbow.rainbow_mapping]
    checked = 0
    for moment, aliases in ALIASES.items():
        for alias in aliases:
            for table in pyart_tables:
                if table.get(alias) is not None:
                    assert table[alias] in PYART_FIELDS[moment], (alias, moment, table[alias])
                    checked += 1
            for table in xradar_tables:
                if alias in table:
                    assert table[alias] in ODIM_NAMES[moment], (alias, moment, table[alias])
                    checked += 1
    assert checked > 40, checked
    every = {a for aliases in ALIASES.values() for a in aliases}
    assert {"DBZHC", "UZ", "DBZ_TOT", "VEL_F", "DBZH_CLEAN"} <= every
    # no name serves two moments
    assert len(every) == sum(len(a) for a in ALIASES.values())


def test_the_names_real_radars_use_map_onto_the_moments():
    from pasim_blocks.truth.field_names import field_map

    # NCAR S-Pol (MDV, Radx): the filtered fields, DBZ_TOT (total power) only without them
    spol = ["DBZ_TOT", "DBZ_F", "VEL_F", "WIDTH_F", "ZDR_F", "RHOHV_F", "PHIDP_F"]
    assert field_map(spol, {}) == {
        "DBZH": "DBZ_F",
        "ZDR": "ZDR_F",
        "RHOHV": "RHOHV_F",
        "PHIDP": "PHIDP_F",
        "VRADH": "VEL_F",
        "WRADH": "WIDTH_F",
    }
    assert field_map(["DBZ_TOT", "VEL"], {}) == {"DBZH": "DBZ_TOT", "VRADH": "VEL"}
    # the mobile X-band file of issue #39 (CfRadial 1): reflectivity under DBZHC
    assert field_map(["DBZHC", "VEL", "ZDR"], {})["DBZH"] == "DBZHC"
    # cleaned before total power; corrected (CZ) before unfiltered (UZ)
    assert field_map(["TH", "DBZH_CLEAN"], {})["DBZH"] == "DBZH_CLEAN"
    assert field_map(["UZ", "CZ"], {})["DBZH"] == "CZ"
    # an LDR radar's co-cross correlation is not RHOHV
    assert "RHOHV" not in field_map(["reflectivity", "co_to_crosspol_correlation_coeff"], {})


def test_fields_names_a_field_first_and_a_field_serves_one_moment():
    from pasim_blocks.truth.field_names import field_map

    names = ["ZH_QC", "TH", "ZDR", "vr_dealiased"]
    given = {"DBZH": "zh_qc", "VRADH": "vr_dealiased"}  # any case, as the aliases
    assert field_map(names, {}, given) == {"DBZH": "ZH_QC", "ZDR": "ZDR", "VRADH": "vr_dealiased"}
    # a field named for one moment is not taken for another by its alias
    assert field_map(["ZDR", "DBZH"], {}, {"RHOHV": "ZDR"}) == {"DBZH": "DBZH", "RHOHV": "ZDR"}
    with pytest.raises(ValueError) as err:
        field_map(names, {}, {"WRADH": "SW"}, "f.nc (CfRadial 1), the 0.50 deg sweep")
    assert str(err.value) == (
        "f.nc (CfRadial 1), the 0.50 deg sweep: fields maps WRADH to 'SW', which it does not "
        "have (its fields: ZH_QC, TH, ZDR, vr_dealiased)"
    )


# ------------------------------------------------------------------------- fields, end to end


@pytest.fixture(scope="module")
def renamed(tmp_path_factory):
    """The ODIM sample written by xradar as CfRadial 1 twice: as it is (DBZH, VRADH) and
    with DBZH and VRADH renamed to names no radar table lists, without their standard
    names, and TH dropped."""
    import xradar

    folder = tmp_path_factory.mktemp("renamed")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tree = xradar.io.open_odim_datatree(str(ODIM))
        plain, odd = folder / "plain.nc", folder / "odd.nc"
        xradar.io.to_cfradial1(tree, plain)
        sweep = tree["sweep_0"].to_dataset()
        sweep = sweep.drop_vars("TH").rename({"DBZH": "DBZ_QC", "VRADH": "V_QC"})
        for name in ("DBZ_QC", "V_QC"):
            sweep[name].attrs.pop("standard_name", None)
        tree["sweep_0"] = sweep
        xradar.io.to_cfradial1(tree, odd)
    return plain, odd


def test_a_file_without_a_known_reflectivity_name_says_how_to_use_fields(renamed):
    from pasim_blocks.truth.radar_files import read_radar_sweep

    _, odd = renamed
    with pytest.raises(ValueError) as err:
        read_radar_sweep(odd, 1.0)
    text = str(err.value)
    assert text.startswith(f"{odd} (CfRadial 1), the 1.00 deg sweep has no reflectivity")
    assert "(its fields: DBZ_QC, V_QC)" in text
    assert "fields: {DBZH: DBZ_QC} in the graph, or --set truth.fields='{DBZH: DBZ_QC}'" in text
    assert "\n" not in text


def test_fields_reads_the_renamed_file_as_the_file_under_standard_names(renamed):
    from pasim_blocks.truth.radar_files import read_radar_sweep

    plain, odd = renamed
    expected = read_radar_sweep(plain, 1.0)
    got = read_radar_sweep(odd, 1.0, fields={"DBZH": "DBZ_QC", "VRADH": "V_QC"})
    assert sorted(got.fields) == sorted(expected.fields) == ["DBZH", "VRADH"]
    for moment, values in expected.fields.items():
        np.testing.assert_array_equal(got.fields[moment], values, err_msg=moment)
    np.testing.assert_array_equal(got.azimuth_deg, expected.azimuth_deg)


def test_a_run_names_the_fields_with_the_option(renamed, tmp_path, capsys):
    """The command line: refused (one line, the hint), then run with --set truth.fields."""
    _, odd = renamed
    base = ["run", GENERIC, "--truth", str(odd), "--set", "truth.elevation_deg=1.0"]
    base += ["--sector", "102:104", "--set", "weather.method=expected"]
    code, _, err = pasim_out(capsys, *base, "--out", str(tmp_path / "a.zarr"))
    assert code == 2 and "--set truth.fields='{DBZH: DBZ_QC}'" in err, err
    assert len([ln for ln in err.splitlines() if ln.startswith("error")]) == 1
    assert "Traceback" not in err
    fields = ["--set", "truth.fields={DBZH: DBZ_QC, VRADH: V_QC}"]
    code, _, err = pasim_out(capsys, *base, *fields, "--out", str(tmp_path / "b.zarr"))
    assert code == 0, err
    assert "no WRADH" in err and "no VRADH" not in err, err


def test_a_name_the_file_lacks_is_refused_before_the_run(renamed, tmp_path, capsys):
    _, odd = renamed
    code, _, err = pasim_out(
        capsys,
        "run",
        GENERIC,
        "--truth",
        str(odd),
        "--set",
        "truth.fields={DBZH: DBZH_QC}",
        "--out",
        str(tmp_path / "s.zarr"),
    )
    assert code == 2, err
    assert f"{odd} (CfRadial 1), the 1.00 deg sweep: fields maps DBZH to 'DBZH_QC'" in err
    assert "(its fields: DBZ_QC, V_QC)" in err and "Traceback" not in err
    assert not (tmp_path / "s.zarr").exists() or not any((tmp_path / "s.zarr").glob("sweep_*"))


@pytest.mark.parametrize(
    ("value", "words"),
    [
        ("{DBZ: x}", "expected keys among DBZH, ZDR, RHOHV, PHIDP, VRADH, WRADH, found 'DBZ'"),
        ("{DBZH: 3}", "expected a mapping of names to names, found 'DBZH': 3"),
        ("{DBZH: a, ZDR: a}", "expected each name once, found 'a' for several keys"),
        ("DBZHC", "expected mapping, found str 'DBZHC'"),
    ],
)
def test_a_bad_fields_value_is_refused_at_validation(value, words, capsys):
    code, _, err = pasim_out(capsys, "validate", GENERIC, "--set", f"truth.fields={value}")
    assert code == 2 and "'fields'" in err and words in err, err


def test_fields_on_a_level2_file_is_refused(tmp_path, capsys):
    code, _, err = pasim_out(
        capsys,
        "run",
        GENERIC,
        "--set",
        "truth.fields={DBZH: REF}",
        "--out",
        str(tmp_path / "s.zarr"),
    )
    assert code == 2 and "names its moments itself" in err and "leave it unset" in err, err


def test_a_note_on_a_missing_moment_lists_the_fields_not_known_by_name():
    """The KASACR file (an LDR radar): no ZDR, RHOHV, PHIDP; the note names the fields the
    truth did not take and how to map one."""
    from pasim_blocks.truth.nexrad import NexradTruth

    from pasim_graph import RunNote

    path = FIXTURES / "truth" / "houkasacrcfrM1.a1.20210922.150006_300gates.nc"
    block = NexradTruth(name="truth", path=str(path), elevation_deg=1.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        block.load()
    notes = [str(w.message) for w in caught if issubclass(w.category, RunNote)]
    (single,) = [n for n in notes if "single polarisation" in n]
    assert "its fields not known by name: co_to_crosspol_correlation_coeff, " in single
    assert "if one of them is ZDR" in single and "truth.fields='{ZDR: <its name>}'" in single
    assert not [n for n in notes if "no VRADH" in n or "no WRADH" in n]  # both by alias


def test_the_coverage_refusal_names_the_support_that_fits():
    """Three RHIs 1 deg apart cover 170.5-173.5 deg: a beam at 172 deg with a 10 deg pattern
    support is refused, naming 1.5 deg; with that support it passes."""
    from pasim_blocks.weather.coverage import check_coverage

    azimuth = np.array([171.0, 172.0, 173.0])
    with pytest.raises(ValueError, match=r"a pattern support of 1\.5 deg would fit every beam"):
        check_coverage(azimuth, 1.0, np.array([172.0]), 10.0)
    check_coverage(azimuth, 1.0, np.array([172.0]), 1.5)


def test_a_mapping_parameter_checks_its_value():
    from pasim_graph import Param

    p = Param(None, type="mapping", choices=("A", "B"), optional=True)
    assert p.check(None) is None and p.check({}) is None and p.check({"A": "x"}) is None
    assert "found 'C'" in str(p.check({"C": "x"}))
    assert "found 'A': ''" in str(p.check({"A": ""}))
    assert "expected mapping" in str(p.check(["A"]))


# ---------------------------------------------------------------------------------- the sweep

FIXTURE_FILES = sorted(
    p.name for p in (FIXTURES / "truth").iterdir() if p.suffix not in (".md", ".py")
)


#: The UF RHIs take longest to read (xradar's UF reader: seconds); the CfRadial 1 RHI made
#: from them takes the same path through the RHI graph by default.
SLOW_FIXTURES = {"MC3E_NPOL_2011_0524_2356_hid_300gates.uf.gz"}


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, marks=pytest.mark.slow) if n in SLOW_FIXTURES else n for n in FIXTURE_FILES],
)
def test_each_fixture_file_runs_through_a_graph_with_its_fields_reported(name, tmp_path):
    """The sweep over tests/fixtures/truth, a file a test: it runs (PPIs through the generic
    radar, the RHIs through the RHI graph), its reflectivity scored on some gates."""
    sweep = sweep_module()
    outcome = sweep.sweep_file(FIXTURES / "truth" / name, "fixture", tmp_path)
    assert outcome.status == "runs", outcome
    assert "DBZH" in outcome.moments and outcome.scored["DBZH"] > 0, outcome
    graph = "RHI graph" if name.startswith("MC3E") else "generic radar"
    assert outcome.setting.startswith(graph), outcome
    assert outcome.row().startswith(f"| `{name}` | fixture | ")


def test_the_sweep_reports_a_refusal_as_one_line(renamed, tmp_path):
    sweep = sweep_module()
    noise = tmp_path / "noise.bin"
    noise.write_bytes(np.random.default_rng(0).bytes(5000))
    unread = sweep.sweep_file(noise, "test", tmp_path)
    assert unread.status == "refused" and "no radar-file reader opens it" in unread.message
    unnamed = sweep.sweep_file(renamed[1], "test", tmp_path)
    assert unnamed.status == "refused", unnamed
    assert "fields: {DBZH: DBZ_QC}" in unnamed.message and str(tmp_path) not in unnamed.message


@pytest.mark.slow
@pytest.mark.skipif(not sweep_module().SHARED.is_dir(), reason="../shared/data is absent")
def test_every_shared_and_pyart_sample_file_runs_or_is_refused_in_one_line():
    """The whole sweep (docs/algorithms.md's table): no file fails otherwise."""
    sweep = sweep_module()
    outcomes = sweep.sweep(sweep.all_files())
    assert len(outcomes) >= 20
    failed = [o for o in outcomes if o.status == "FAILED"]
    assert not failed, "\n".join(o.row() for o in failed)
    shared = [o for o in outcomes if o.source == "../shared/data"]
    assert all(o.status == "runs" for o in shared), "\n".join(o.row() for o in shared)


def pyart_sample(name: str):
    """A sample file Py-ART ships (found without importing Py-ART)."""
    where = importlib.util.find_spec("pyart")
    if where is None or not where.submodule_search_locations:
        pytest.skip("Py-ART is not installed")
    path = next(iter(where.submodule_search_locations)) + f"/testing/data/{name}"
    return path


def test_a_sweep_of_one_ray_is_refused_as_not_a_ppi():
    """Py-ART's UF sample holds one ray (its azimuth spacing is undefined: the weather channel
    failed on it with numpy's words)."""
    from pasim_blocks.truth.radar_files import read_radar_sweep

    with pytest.raises(ValueError, match=r"is not a PPI: its 1 ray\(s\) lie within 0 deg"):
        read_radar_sweep(pyart_sample("example_uf_ppi.uf"), 0.5)


@pytest.mark.slow  # 31 sweeps read: 6 s on a quiet machine
def test_a_sector_scan_is_read_with_its_own_spacing_and_refused_outside_its_sector():
    """Py-ART's cloud-radar raster: PPIs over 0.5-5.5 deg at about 0.03 deg, the lowest with
    the antenna standing at its start for 200 rays. Its spacing is the moving rays' (the
    median of the distinct azimuths' steps, computed here), and a sector away from it is
    refused naming where its radials are (the scan block failed on an empty sequence)."""
    from pasim_blocks.truth.radar_files import open_radar_file, read_radar_sweep

    path = pyart_sample("example_cfradial_cr_raster.nc")
    tree, _ = open_radar_file(path)
    azimuth = tree["sweep_0"].to_dataset()["azimuth"].values.astype(np.float64)
    distinct = np.unique(np.round(azimuth, 3))
    sweep = read_radar_sweep(path, -0.47)
    assert sweep.radial_width_deg == pytest.approx(np.median(np.diff(distinct)))
    assert 0.02 < sweep.radial_width_deg < 0.05
    with pytest.raises(ValueError) as err:
        read_radar_sweep(path, 0.5, sector_deg=(240.0, 330.0), margin_deg=10.0)
    assert "no radial within 10 deg of the sector 240:330 deg" in str(err.value)
    assert "lie from 0.5 to 5.3 deg" in str(err.value)


def test_the_issue_case_a_cfradial1_rhi_with_dbzhc_reads_as_its_source():
    """Issue #39's file: a CfRadial 1 RHI (character-array times) whose reflectivity is
    DBZHC, made by Py-ART from the UF sample (tests/fixtures/truth/make_dbzhc_rhi.py). Read
    by alias, its DBZH equals the UF sample's reflectivity on the same rays and gates (the
    same values through another format and another writer), and its start time is read."""
    from pasim_blocks.truth.radar_files import open_radar_file
    from pasim_blocks.truth.rhi_files import rhi_sweeps

    made = FIXTURES / "truth" / "MC3E_NPOL_rhi_DBZHC_cfradial1.nc.gz"
    source = FIXTURES / "truth" / "MC3E_NPOL_2011_0524_2356_hid_300gates.uf.gz"
    tree, kind = open_radar_file(made)
    assert kind == "CfRadial 1"
    assert "DBZHC" in tree["sweep_0"].to_dataset().data_vars
    got = rhi_sweeps(tree, kind, made, lambda grid: [2.0, 5.0])
    source_tree, source_kind = open_radar_file(source)
    expected = rhi_sweeps(source_tree, source_kind, source, lambda grid: [2.0, 5.0])
    for a, b in zip(got, expected, strict=True):
        assert a.elevation_deg == pytest.approx(b.elevation_deg)
        np.testing.assert_allclose(a.fields["DBZH"], b.fields["DBZH"][:, :80], atol=0.01)
        assert np.isfinite(a.fields["DBZH"]).sum() > 50
    assert got[0].site["time_coverage_start"] == "2011-05-24T23:56:01Z"
    # RHIs take fields too: the field named for DBZH is the one read, and ZDR, taken, is
    # not read again for ZDR
    named = rhi_sweeps(source_tree, source_kind, source, lambda grid: [2.0], {"DBZH": "ZDR"})[0]
    np.testing.assert_array_equal(named.fields["DBZH"], expected[0].fields["ZDR"])
    assert "ZDR" not in named.fields and "RHOHV" in named.fields


@pytest.mark.slow  # two study checks: 5 s on a quiet machine
def test_a_study_case_names_its_truth_fields(renamed, tmp_path, capsys):
    """A study case takes ``fields`` for its truth file, checked like the block's parameter
    and given to every system's truth block: without it the renamed file is refused by
    the study's check (with the hint), with it the study checks clean."""
    import shutil

    from pasim_blocks.study.model import parse_study

    for graph in ("small_pencil.yaml", "small_wide.yaml"):
        shutil.copy(FIXTURES / "study" / graph, tmp_path / graph)
    _, odd = renamed
    case = f'{{name: odd, truth: {odd}, sector: "102:104", elevation: 1.0'
    text = (
        "format: pasim-study/1\nsystems:\n  - {name: narrow, graph: small_pencil.yaml}\n"
        f"cases:\n  - {case}FIELDS}}\nseeds: [0]\n"
    )
    study = tmp_path / "study.yaml"
    study.write_text(text.replace("FIELDS", ""))
    code, _, err = pasim_out(capsys, "study", str(study), "--check")
    assert code == 2 and "fields: {DBZH: DBZ_QC}" in err and "Traceback" not in err, err
    study.write_text(text.replace("FIELDS", ", fields: {DBZH: DBZ_QC, VRADH: V_QC}"))
    code, out, err = pasim_out(capsys, "study", str(study), "--check")
    assert code == 0, out + err
    bad = parse_study(text.replace("FIELDS", ", fields: {DBZ: x}"), str(study))
    assert any("expected keys among DBZH" in str(p) for p in bad.problems), bad.problems
