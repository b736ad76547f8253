"""Every study shipped in graphs/ validates whole (its graphs, overrides, sweeps and truth),
and every file of graphs/ is either a graph or a study."""

from __future__ import annotations

import pytest
from pasim_blocks.study.model import FORMAT, read_study
from pasim_blocks.study.plan import plan_runs

from ..conftest import GRAPHS

STUDIES = sorted(GRAPHS.glob("*_study.yaml"))


def test_every_file_in_graphs_is_a_graph_or_a_study():
    for path in GRAPHS.glob("*.yaml"):
        first = path.read_text().splitlines()[0]
        is_study = first == f"format: {FORMAT}"
        assert is_study == path.name.endswith("_study.yaml"), path.name


@pytest.mark.parametrize("path", STUDIES, ids=lambda p: p.name)
def test_study_validates(path):
    study = read_study(path)
    assert not study.problems, study.problems
    runs, problems = plan_runs(study)
    assert not problems, "\n".join(map(str, problems))
    points = sum(len(study.points(s.name)) for s in study.systems) * len(study.cases)
    # Per point: an estimate and an expected level per seed, and the two budget references;
    # at an unswept point, an estimate under each other calibration the antenna offers.
    calibrations = [r for r in runs if r.kind.startswith("calibration_")]
    assert len(runs) - len(calibrations) == points * (2 * len(study.seeds) + 2)
    assert all(r.point == {} and r.seed == study.seeds[0] for r in calibrations)


def test_the_paper_study_runs_each_array_under_boresight_calibration_too():
    runs, _ = plan_runs(read_study(GRAPHS / "paper_study.yaml"))
    kinds = {(r.system, r.kind) for r in runs if r.kind.startswith("calibration_")}
    # The generic radar's pencil beam has no calibration choice; the arrays calibrate per beam.
    assert kinds == {(s, "calibration_boresight") for s in ("atd", "cppar2", "cppar10")}


def test_the_bits_study_sweeps_the_phase_shifter_bits():
    study = read_study(GRAPHS / "bits_study.yaml")
    (sweep,) = study.sweeps
    assert sweep.values == {"antenna.phase_bits": [3, 4, 5, 6, 7, 8]}
