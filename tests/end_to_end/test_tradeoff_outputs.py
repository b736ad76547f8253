"""`pasim run --outputs` (model only what is asked for) and `pasim tradeoff` end to end."""

from __future__ import annotations

import json
import re

import numpy as np
import xarray as xr

from ..conftest import GRAPHS, pasim_result

GENERIC = str(GRAPHS / "generic_radar.yaml")
SMALL = ["--sector", "282:285", "--set", "scan.pulses=16", "--seed", "5"]


def test_outputs_dbzh_gives_the_same_dbzh_and_nothing_else(tmp_path, capsys):
    full, only = tmp_path / "full.zarr", tmp_path / "dbzh.zarr"
    res = pasim_result(capsys, "run", GENERIC, *SMALL, "--out", str(full))
    assert res.returncode == 0, res.stderr
    res = pasim_result(capsys, "run", GENERIC, *SMALL, "--outputs", "DBZH", "--out", str(only))
    assert res.returncode == 0, res.stderr
    a = xr.open_datatree(full, engine="zarr")["sweep_0"]
    b = xr.open_datatree(only, engine="zarr")["sweep_0"]
    np.testing.assert_array_equal(a["DBZH"].values, b["DBZH"].values)
    for name in ("ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"):
        assert name in a and name not in b
    scores = json.loads(pasim_result(capsys, "score", str(only), "--json").stdout)
    assert list(scores) == ["DBZH"] and scores["DBZH"]["count"] > 100


def test_unknown_output_field_is_refused_before_running(tmp_path, capsys):
    res = pasim_result(
        capsys, "run", GENERIC, *SMALL, "--outputs", "DBZH,DBZX", "--out", str(tmp_path / "x")
    )
    assert res.returncode == 2
    assert "DBZX" in res.stderr and "ZDR" in res.stderr and "Traceback" not in res.stderr
    assert not (tmp_path / "x").exists()


def test_tradeoff_json_rows(tmp_path, capsys):
    res = pasim_result(
        capsys, "tradeoff", GENERIC, *SMALL, "--levels", "expected,combined,covariance", "--json"
    )
    assert res.returncode == 0, res.stderr
    rows = json.loads(res.stdout)
    assert [r["level"] for r in rows] == ["expected", "combined", "covariance"]
    for r in rows:
        assert r["seconds"] > 0 and r["peak_memory_mb"] > 50
        assert set(r["std"]) == {"DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"}
        assert r["method"] == r["level"] and r["reference"] == "covariance"
    # The reference against itself differs by nothing; the random levels differ from it by
    # their estimator noise, the expected level by the reference's noise alone.
    assert all(v == 0 for v in rows[2]["std_vs_reference"].values())
    assert rows[1]["std_vs_reference"]["DBZH"] > rows[0]["std_vs_reference"]["DBZH"] > 0
    # No estimator noise: the expected level is closer to the truth than a 16-pulse dwell.
    assert rows[0]["std"]["DBZH"] < rows[1]["std"]["DBZH"]
    # Progress on standard error while each level runs (it ran for minutes with none), the
    # table alone on standard output.
    for i, level in enumerate(["expected", "combined", "covariance"]):
        assert f"level {level} ({i + 1} of 3)" in res.stderr, res.stderr
        assert re.search(rf"level {level}: (\d+) of \1 chunks", res.stderr), res.stderr
    assert "chunks" not in res.stdout


def test_tradeoff_unknown_level(capsys):
    res = pasim_result(capsys, "tradeoff", GENERIC, *SMALL, "--levels", "fastest")
    assert res.returncode == 2 and "fastest" in res.stderr and "expected" in res.stderr


def test_truth_sector_follows_a_scan_left_at_its_defaults(tmp_path, capsys):
    """The truth reads the scan's sector even when the graph file leaves it to the defaults."""
    text = (GRAPHS / "generic_radar.yaml").read_text()
    text = text.replace("azimuth_start_deg: 240.0, azimuth_stop_deg: 330.0, ", "")
    graph = tmp_path / "defaults.yaml"
    graph.write_text(text)
    res = pasim_result(capsys, "validate", str(graph), "--json")
    assert res.returncode == 0, res.stderr
