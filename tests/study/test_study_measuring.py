"""The study's antenna and hardware measurements as tasks on its cluster (blocks.study.measuring):
the same figures as measured in the study's own process, kept as they come, every one in
by the end; a failure is raised where the study waits for it."""

from __future__ import annotations

import json

import pytest
from pasim_blocks.study.measuring import Measuring
from pasim_blocks.study.model import read_study
from pasim_blocks.study.plan import plan_runs
from pasim_blocks.study.runner import ensure_patterns, measure_ahead

from ..conftest import TINY_STUDY


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("distributed")
    with distributed.Client(
        processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None
    ) as c:
        yield c


def _fail(x: int) -> dict:
    raise ValueError(f"no pattern for {x}")


def test_measured_on_the_cluster_as_in_the_study(tmp_path, client, tiny_study):
    """Both systems' patterns and hardware measured as cluster tasks from the tiny study's
    finished runs: what the serial study (the tiny_study fixture, measured in its own
    process) kept in its manifest, to the last digit (as JSON)."""
    import shutil

    shutil.copytree(tiny_study / "runs", tmp_path / "runs")
    runs, problems = plan_runs(read_study(TINY_STUDY))
    assert not problems
    state: dict = {}
    lines: list[str] = []
    saved: list[int] = []
    measuring = Measuring(state, lambda: saved.append(1), lines.append)
    measuring.client = client
    ensure_patterns(read_study(TINY_STUDY), runs, tmp_path, measuring)
    assert not state.get("patterns") and not state.get("hardware")  # sent, not measured here
    assert not measuring.wanted("patterns", "narrow/convective/-")  # in flight: not twice
    measuring.gather(wait=True)
    serial = json.loads((tiny_study / "pasim-study.json").read_text())
    for part in ("patterns", "hardware"):
        assert json.loads(json.dumps(state[part])) == serial[part], part
    assert sorted(line.rsplit(": ", 1)[0] for line in lines) == [
        "measured the antenna of narrow/convective/-",
        "measured the antenna of wide/convective/-",
        "measured the hardware of narrow",
        "measured the hardware of wide",
    ]
    assert all(line.endswith(" s") for line in lines), lines
    assert len(lines) == 4 and len(saved) == 4
    # Each task's record kept with them (the serial study's too): what, where, when, its CPU.
    for kept in (state, serial):
        records = kept["measurements"]
        assert sorted((m["kind"], m["key"]) for m in records) == sorted(
            (part, key) for part in ("patterns", "hardware") for key in kept[part]
        )
        for m in records:
            assert m["start"] <= m["stop"] and m["cpu_s"] >= 0 and m["worker_cpu_s"] > 0
            assert m["worker"].split(":")[0]  # host:pid[/thread]
    # And the study's process while its runs ran (this one serial: no workers).
    ((process,),) = [serial["process"]]
    assert process["start"] < process["stop"] and process["cpu_s"] > 0
    assert process["workers"] is None


def test_measured_ahead_as_each_estimate_starts_as_in_the_study(tmp_path, client, tiny_study):
    """On a cluster the study measures a first-seed estimate's antenna (and with its
    system's first estimate the hardware) as the run starts, from the beams its store will
    hold, before any chunk: the figures the serial study measured from the finished stores,
    to the last digit (as JSON), each once however many of the system's runs start."""
    from pasim_graph.dask_executor import DaskExecutor
    from pasim_graph.executor import RunOptions

    study = read_study(TINY_STUDY)
    runs, problems = plan_runs(study)
    assert not problems
    state: dict = {}
    lines: list[str] = []
    measuring = Measuring(state, lambda: None, lines.append)
    measuring.client = client
    for run in runs:  # every run, as the study starts them: only the estimates measure
        executor = DaskExecutor(run.graph(), RunOptions(seed=run.seed))
        measure_ahead(study, run, runs, executor, measuring)
    assert not state.get("patterns") and not state.get("hardware")  # sent, not measured here
    measuring.gather(wait=True)
    serial = json.loads((tiny_study / "pasim-study.json").read_text())
    for part in ("patterns", "hardware"):
        assert json.loads(json.dumps(state[part])) == serial[part], part
    assert len(lines) == 4, lines
    assert not list(tmp_path.iterdir())  # nothing written: no store was needed


def test_stores_read_on_the_cluster_are_the_stores_read_here(client, tiny_study):
    """A study on a cluster reads each finished store's errors as a task: the token and every
    array are those read in the study's process; a read in flight can be dropped."""
    import numpy as np
    from pasim_blocks.study.reading import StoreReading, read_store

    stores = sorted((tiny_study / "runs").rglob("*.zarr"))[:3]
    read: dict = {}
    reading = StoreReading(read, client)
    for path in stores:
        reading.add(path.name + str(stores.index(path)), path)
    assert not read  # sent, not read here
    reading.collect()
    assert len(read) == len(stores)
    for i, path in enumerate(stores):
        token, errors = read[path.name + str(i)]
        here_token, here = read_store(str(path))
        assert token == here_token and errors.fields.keys() == here.fields.keys()
        for name in here.fields:
            np.testing.assert_array_equal(errors.fields[name], here.fields[name])
        assert errors.requirements == here.requirements
    reading.add("again", stores[0])
    reading.drop()
    reading.collect()
    assert "again" not in read


def test_a_failed_measurement_is_raised_where_the_study_waits(client):
    state: dict = {}
    measuring = Measuring(state, lambda: None, lambda s: None)
    measuring.client = client
    measuring.start("patterns", "a/b/-", "the antenna of a/b/-", _fail, 3)
    with pytest.raises(ValueError, match="no pattern for 3"):
        measuring.gather(wait=True)
    assert "a/b/-" not in state.get("patterns", {})


def test_the_report_drawn_on_the_cluster_is_the_report_drawn_here(client, tiny_study):
    """Every figure of the tiny study's report drawn as cluster tasks (two worker threads:
    one figure at a time per worker process) is the one drawn here, byte for byte, in the
    same place."""
    from pasim_blocks.study.figures import Drawing
    from pasim_blocks.study.report import build

    here, there = build(tiny_study), build(tiny_study, Drawing(client))

    def figures(context: dict) -> list:
        out = [("hardware", f.title, f.uri) for f in context["hardware_figures"]]
        for case in context["cases"]:
            for kind, figs in case.figures.items():
                out += [(case.name, kind, f.title, f.uri) for f in figs]
        return out

    assert len(figures(here)) >= 8
    assert figures(there) == figures(here)
    assert [c.name for c in there["cases"]] == [c.name for c in here["cases"]]
    assert there["notes"] == here["notes"]
