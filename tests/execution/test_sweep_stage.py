"""Sweep-level blocks (pasim_graph.sweep_stage): once per sweep, on the whole sweep, after its
chunks; the same stored numbers at any chunking, after a kill and --resume; refused where a
connection cannot be served."""

from __future__ import annotations

import argparse
import re

import numpy as np
import pytest
import xarray as xr
import zarr
from pasim_blocks.signals import MOMENTS

from pasim_graph import DATASET, Block, Input, Output, PortType, Schema, Var
from pasim_graph.block import TYPE_NAMES
from pasim_graph.store import mark_incomplete, run_state
from pasim_graph.sweep_level import stage_problems
from pasim_graph.sweep_stage import STAGE_DONE
from pasim_graph.task_record import read_tasks

from ..conftest import GRAPHS, kill_run_part_way, pasim_out, run_cli

DEALIAS = str(GRAPHS / "dealias_cband.yaml")
#: 12 beams where the storm's velocities fold at C band and PRT 2 ms, 16 pulses.
SMALL = ["--sector", "296:308", "--set", "scan.pulses=16"]
STAGE = "VRADH_DEALIASED_REGION"


def sweep(path) -> xr.Dataset:
    return xr.open_datatree(path, engine="zarr")["sweep_0"].to_dataset()


def assert_same_sweep(a: xr.Dataset, b: xr.Dataset) -> None:
    assert sorted(a.data_vars) == sorted(b.data_vars)
    for name in a.data_vars:
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=str(name))


def stage_runs(path) -> list[int]:
    """How many times each run of the store ran a sweep stage (its task record)."""
    return [sum(s["kind"] == "sweep stage" for s in r["steps"]) for r in read_tasks(path)]


ANOMALY = PortType(
    "anomaly",
    DATASET,
    ("beam", "range"),
    "cfradial",
    Schema({"DBZH_ANOMALY": Var("float32", ("beam", "range"), "dB", "DBZH minus its sweep mean")}),
)


class SweepAnomaly(Block):
    """DBZH minus its mean over the whole sweep: a result no chunk can compute alone."""

    sweep_level = True
    moments = Input(MOMENTS)
    anomaly = Output(ANOMALY, store="moments")

    def process(self, inputs, chunk):
        dbz = inputs["moments"]["DBZH"]
        assert chunk.beams.size == dbz.sizes["beam"]  # the whole sweep, as one chunk
        value = (dbz.values - float(dbz.mean())).astype(np.float32)
        anomaly = (("beam", "range"), value, {"units": "dB"})
        return {"anomaly": xr.Dataset({"DBZH_ANOMALY": anomaly})}


@pytest.fixture
def toy_graph(tmp_path, monkeypatch):
    """uniform_ideal.yaml on 12 beams of 100 gates, with a sweep-level block."""
    from pasim_graph import registry

    monkeypatch.setitem(registry._loaded, "test.sweep_anomaly", SweepAnomaly)
    monkeypatch.setitem(TYPE_NAMES, SweepAnomaly, "test.sweep_anomaly")
    text = (GRAPHS / "uniform_ideal.yaml").read_text()
    text = text.replace("blocks:\n", "blocks:\n  anomaly: {type: test.sweep_anomaly}\n", 1)
    text = text.replace("connections:\n", "connections:\n  - ppp.moments -> anomaly.moments\n", 1)
    path = tmp_path / "toy.yaml"
    path.write_text(text)
    return [str(path), "--sector", "0:12", "--set", "scan.pulses=8"]


def test_sweep_level_block_gives_the_same_fields_at_any_chunking(capsys, tmp_path, toy_graph):
    """Chunks of 1, 8 and 90 beams store the same fields, the sweep-level one included, as
    the in-memory executor; the stage saw the whole sweep (its anomaly is DBZH minus the
    mean of every stored DBZH, computed here independently)."""
    from pasim_graph.cli import load_graph
    from pasim_graph.executor import LocalExecutor, RunOptions

    stores = []
    for chunk in ("1", "8", "90"):
        out = tmp_path / f"c{chunk}.zarr"
        code, _, err = pasim_out(capsys, "run", *toy_graph, "--chunk", chunk, "--out", str(out))
        assert code == 0, err
        stores.append(sweep(out))
    for other in stores[1:]:
        assert_same_sweep(stores[0], other)
    dbz = stores[0]["DBZH"].values.astype(np.float64)
    expected = (dbz - dbz.mean()).astype(np.float32)
    np.testing.assert_allclose(stores[0]["DBZH_ANOMALY"].values, expected, atol=1e-4)
    assert abs(dbz[:8].mean() - dbz.mean()) > 1e-3  # a chunk's own mean differs
    args = argparse.Namespace(graph=toy_graph[0], truth=None, sector="0:12", set=["scan.pulses=8"])
    memory = LocalExecutor(load_graph(args), RunOptions(chunk_beams=5)).run()
    np.testing.assert_array_equal(memory["DBZH_ANOMALY"].values, stores[0]["DBZH_ANOMALY"].values)


def test_killed_stage_is_run_again_and_a_finished_one_is_not(capsys, tmp_path, toy_graph):
    """A store whose chunks are all written but whose stage did not finish (its flag unset,
    its arrays half written, as a kill during the stage leaves them) is completed by
    --resume to the numbers of a run never interrupted; a finished stage is not run again."""
    full = tmp_path / "full.zarr"
    args = ["run", *toy_graph, "--chunk", "4"]
    assert pasim_out(capsys, *args, "--out", str(full))[0] == 0
    reference = sweep(full)
    assert stage_runs(full) == [1]

    # Killed in the stage: the flag is unset, a stage array holds garbage.
    mark_incomplete(full)
    group = zarr.open_group(str(full), path="sweep_0", mode="r+", use_consolidated=False)
    del group.attrs[STAGE_DONE]
    group["DBZH_ANOMALY"][:] = 0.0
    code, _, err = pasim_out(capsys, *args, "--out", str(full), "--resume")
    assert code == 0, err
    assert_same_sweep(sweep(full), reference)
    assert stage_runs(full) == [1, 1]
    assert run_state(full)[0]["pasim_complete"] == "true"

    # Stopped after the stage finished (the completion marker not yet written): not rerun.
    mark_incomplete(full)
    code, _, err = pasim_out(capsys, *args, "--out", str(full), "--resume")
    assert code == 0, err
    assert stage_runs(full) == [1, 1, 0]
    assert_same_sweep(sweep(full), reference)

    # A stage array removed from a finished store: --resume runs the stage again.
    group = zarr.open_group(str(full), path="sweep_0", mode="r+", use_consolidated=False)
    del group["DBZH_ANOMALY"]
    code, _, err = pasim_out(capsys, *args, "--out", str(full), "--resume")
    assert code == 0, err
    assert "missing array(s)" in err and stage_runs(full)[-1] == 1
    assert_same_sweep(sweep(full), reference)


@pytest.mark.slow
def test_dealiasing_stage_gives_the_same_fields_at_any_chunking(capsys, tmp_path):
    """The must-show on the bundled storm: region-based dealiasing (graphs/dealias_cband.yaml,
    12 beams where the velocities fold) stores the same fields with chunks of 1, 8 and 90
    beams."""
    stores = []
    for chunk in ("1", "8", "90"):
        out = tmp_path / f"c{chunk}.zarr"
        code, _, err = pasim_out(
            capsys, "run", DEALIAS, *SMALL, "--chunk", chunk, "--out", str(out)
        )
        assert code == 0, err
        stores.append(sweep(out))
    assert STAGE in stores[0] and f"error_{STAGE}" in stores[0]
    for other in stores[1:]:
        assert_same_sweep(stores[0], other)
    # The stage unfolded something: its velocity differs from the folded one by 2 v_a.
    v, d = stores[0]["VRADH"].values, stores[0][STAGE].values
    assert np.nanmax(np.abs(d - v)) > 10.0
    # Its error is scored beside the moments.
    code, out, _ = pasim_out(capsys, "score", str(tmp_path / "c8.zarr"))
    assert code == 0 and re.search(rf"^{STAGE}\s", out, re.M), out


@pytest.mark.slow
def test_sigkill_during_the_chunks_then_resume(tmp_path):
    """SIGKILL part-way through the chunks, then --resume: the stage runs once the chunks are
    complete, and the store equals one never interrupted (separate processes: slow)."""
    args = ["run", DEALIAS, *SMALL, "--chunk", "1", "--scheduler", "sync"]
    killed = tmp_path / "killed.zarr"
    kill_run_part_way(args, killed)
    assert run_state(killed)[0]["pasim_complete"] == "false"
    assert STAGE not in zarr.open_group(str(killed), path="sweep_0", mode="r")
    res = run_cli(*args, "--out", str(killed), "--resume")
    assert res.returncode == 0, res.stderr
    full = tmp_path / "full.zarr"
    res = run_cli(*args, "--out", str(full))
    assert res.returncode == 0, res.stderr
    assert_same_sweep(sweep(killed), sweep(full))


SWEEP = PortType("toy", "float32", ("beam", "range"), "1")


class PerChunk(Block):
    beams_in = Input(SWEEP, required=False)
    stored = Output(SWEEP, store="moments")
    loose = Output(SWEEP)


class SweepLevel(Block):
    sweep_level = True
    data = Input(SWEEP)
    out = Output(SWEEP, store="moments")


def test_connections_a_sweep_stage_cannot_serve_are_named():
    """A sweep-level block reads stored outputs only, and only sweep-level blocks read its
    outputs (they exist after every chunk)."""
    from pasim_graph.graph import Edge

    classes = {"a": PerChunk, "s": SweepLevel, "t": SweepLevel}
    good = [Edge("a", "stored", "s", "data"), Edge("s", "out", "t", "data")]
    assert stage_problems(classes, good) == []
    unstored = stage_problems(classes, [Edge("a", "loose", "s", "data")])
    assert len(unstored) == 1 and unstored[0][0] == "s" and "not stored" in unstored[0][1]
    backwards = stage_problems(classes, [Edge("s", "out", "a", "beams_in")])
    assert len(backwards) == 1 and "only another sweep-level block" in backwards[0][1]
    assert SweepLevel.interface()["sweep_level"] is True


def test_outputs_leave_the_sweep_level_blocks_out(toy_graph):
    """--outputs DBZH computes some moments only: the sweep-level blocks, which read whole
    sweeps of the moments, are not planned."""
    from pasim_graph.cli import load_graph
    from pasim_graph.executor import RunOptions, plan

    args = argparse.Namespace(graph=toy_graph[0], truth=None, sector="0:12", set=[])
    graph = load_graph(args)
    assert plan(graph, RunOptions()).sweep_level == ["anomaly"]
    assert plan(graph, RunOptions(fields=("DBZH",))).sweep_level == []
