"""A study case whose weather is the whole volume (``sweeps: volume``), not one sweep.

The case option reaches every run of every system (estimate, expected and reference runs) as
the truth block's own ``sweeps`` and ``elevation_interpolation``; bad values are named with
their line before any run; and the study's estimate store is the one a plain ``pasim run``
with the same settings writes (an independent path to the same numbers).
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.study.model import parse_study, read_study
from pasim_blocks.study.plan import plan_runs
from pasim_blocks.study.report import case_truth_text

from pasim_graph.cli import main

FIX = Path(__file__).parents[1] / "fixtures" / "study"

STUDY = """format: pasim-study/1
systems:
  - {name: narrow, graph: small_pencil.yaml}
cases:
  - {name: flat, truth: "", sector: "280:283", elevation: 3.4}
  - {name: storm3d, truth: "", sector: "280:283", elevation: 3.4,
     sweeps: volume, interpolation: linear}
seeds: [0]
"""


def test_bad_volume_options_are_named_with_their_line():
    text = STUDY.replace("sweeps: volume, interpolation: linear", "sweeps: stack").replace(
        "elevation: 3.4}\n  - {name: storm3d",
        "elevation: 3.4, interpolation: linear}\n  - {name: storm3d",
    )
    problems = "\n".join(str(p) for p in parse_study(text, "s.yaml").problems)
    assert "s.yaml:5" in problems and "'interpolation' needs sweeps: volume" in problems
    assert "s.yaml:6" in problems and "sweeps 'stack': expected one of single, volume" in problems


def test_a_volume_case_reaches_every_run_of_every_system(tmp_path):
    shutil.copy(FIX / "small_pencil.yaml", tmp_path)
    (tmp_path / "study.yaml").write_text(STUDY)
    runs, problems = plan_runs(read_study(tmp_path / "study.yaml"))
    assert problems == []
    by_case: dict[str, list] = {"flat": [], "storm3d": []}
    for run in runs:
        by_case[run.case].append(run)
    assert {r.kind for r in by_case["storm3d"]} == {r.kind for r in by_case["flat"]}
    for run in by_case["storm3d"]:
        g = run.graph()
        assert [g.value(t, "sweeps") for t in g.by_role("truth")] == ["volume"], run.kind
        assert [g.value(t, "elevation_interpolation") for t in g.by_role("truth")] == ["linear"]
    for run in by_case["flat"]:
        g = run.graph()
        assert [g.value(t, "sweeps") for t in g.by_role("truth")] == ["single"], run.kind


def test_a_truth_block_without_volumes_is_refused_by_name(tmp_path):
    graph = (FIX / "small_pencil.yaml").read_text()
    (tmp_path / "small_pencil.yaml").write_text(
        graph.replace(
            "truth:    {type: truth.nexrad, params: {elevation_deg: 0.5}}",
            "truth:    {type: scene.uniform}",
        )
    )
    (tmp_path / "study.yaml").write_text(STUDY)
    _, problems = plan_runs(read_study(tmp_path / "study.yaml"))
    text = "\n".join(str(p) for p in problems)
    assert "case 'storm3d'" in text and "cannot read the case's truth as a volume" in text


def test_the_report_says_how_the_case_fills_elevation():
    flat = {"truth": "", "sector_deg": [280, 283], "elevation_deg": 3.4, "sweeps": "single"}
    assert "nearest sweep, taken as uniform in elevation" in case_truth_text(flat)
    volume = flat | {"sweeps": "volume", "interpolation": "linear"}
    assert "every sweep of the volume, linear between sweeps" in case_truth_text(volume)


@pytest.mark.filterwarnings("ignore")
def test_the_study_runs_the_volume_as_pasim_run_does(tmp_path):
    shutil.copy(FIX / "small_pencil.yaml", tmp_path)
    study = tmp_path / "study.yaml"
    study.write_text(STUDY)
    out = tmp_path / "out"
    assert main(["study", str(study), "--out", str(out)]) == 0
    (estimate,) = (out / "runs").glob("narrow/storm3d/*/estimate-seed0.zarr")
    alone = tmp_path / "alone.zarr"
    args = ["run", str(tmp_path / "small_pencil.yaml"), "--out", str(alone), "--sector", "280:283"]
    for s in (
        "scan.elevation_deg=3.4",
        "truth.elevation_deg=3.4",
        "truth.sweeps=volume",
        "truth.elevation_interpolation=linear",
        "truth.azimuth_start_deg=280",
        "truth.azimuth_stop_deg=283",
    ):
        args += ["--set", s]
    assert main(args) == 0

    def sweep(path: Path) -> xr.Dataset:
        return xr.open_datatree(path, engine="zarr")["sweep_0"].to_dataset()

    a, b = sweep(estimate), sweep(alone)
    for name in ("DBZH", "ZDR", "truth_DBZH"):
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    # The same run on the single 3.4 deg sweep is other weather: the comparison can fail.
    flat = tmp_path / "flat.zarr"
    single = [x.replace("=volume", "=single").replace("=linear", "=nearest") for x in args]
    assert main([*single[:3], str(flat), *single[4:]]) == 0
    assert not np.array_equal(sweep(flat)["DBZH"].values, a["DBZH"].values, equal_nan=True)
    assert np.isfinite(a["DBZH"].values).sum() > 100
    meta = json.loads((out / "scores.json").read_text())["_study"]["cases"]["storm3d"]
    assert meta["sweeps"] == "volume" and meta["interpolation"] == "linear"
    report = (out / "report.html").read_text()
    assert "every sweep of the volume, linear between sweeps in elevation" in report
    assert "its nearest sweep, taken as uniform in elevation" in report
    # Two cases in one page: every id once, and the navigation reaches each case.
    ids = re.findall(r'\bid="([^"]+)"', report)
    assert len(ids) == len(set(ids)), sorted(i for i in ids if ids.count(i) > 1)
    for target in re.findall(r'href="#([^"]+)"', report):
        assert target in ids, target
    assert 'href="#summary-storm3d"' in report
