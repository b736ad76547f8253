"""What a chunk task is sent: the executor without the once-per-run blocks' resources (their
outputs travel once, with the run's shared inputs), computing the same chunk to the bit."""

from __future__ import annotations

import pickle

import numpy as np
import xarray as xr

from pasim_graph.executor import LocalExecutor, RunOptions, merge_products
from pasim_graph.graph import load

from ..conftest import GRAPHS


def test_a_chunk_task_gets_the_per_chunk_blocks_resources_only():
    sector = {"scan.azimuth_start_deg": 280.0, "scan.azimuth_stop_deg": 284.0}
    executor = LocalExecutor(load(GRAPHS / "generic_radar.yaml", sector), RunOptions(chunk_beams=2))
    executor.load()
    static = executor.run_static()
    assert "truth" in executor.plan.static and executor.plan.resources["truth"] is not None
    shipped = pickle.loads(pickle.dumps(executor.for_chunks()))
    assert set(shipped.plan.resources) == set(executor.plan.per_chunk) & set(
        executor.plan.resources
    )
    assert "truth" not in shipped.plan.resources
    assert executor.plan.resources["truth"] is not None  # the run's own executor keeps it
    # The truth's sweep was most of what a worker was sent.
    assert len(pickle.dumps(shipped)) < len(pickle.dumps(executor)) / 2
    beams = np.arange(2, 4)
    xr.testing.assert_identical(
        merge_products(shipped.run_chunk(static, beams)),
        merge_products(executor.run_chunk(static, beams)),
    )


def test_chunks_are_started_as_interleaved_runs_of_neighbours():
    """Two chunk slots take 0, 5, 1, 6, ...: each the chunk after its last (the truth near a
    beam is prepared once per worker, by blocks of radials); every chunk once."""
    from pasim_graph.chunk_tasks import neighbours_first

    todo = [3, 4, 5, 6, 7, 8, 9, 10, 11, 12]
    rank = neighbours_first(todo, 2)
    assert sorted(todo, key=rank.get) == [3, 8, 4, 9, 5, 10, 6, 11, 7, 12]
    assert sorted(rank.values()) == list(range(len(todo)))
    three = neighbours_first(list(range(7)), 3)
    assert sorted(range(7), key=three.get) == [0, 2, 5, 1, 3, 6, 4]
    assert len(set(three.values())) == 7
    assert neighbours_first(todo, 1) == {i: n for n, i in enumerate(todo)}
    assert neighbours_first([7], 16) == {7: 0}


def test_the_first_three_quarters_of_each_run_of_neighbours_ask_for_its_worker():
    """Each slot's run of neighbours (a worker of two threads has two) is asked of its worker
    for its first three quarters: a worker takes the chunk after its last even when the other
    frees first; the last quarter goes to whichever is free (the runs' unequal costs evened
    out there). The asking is loose: a worker lost, the chunk runs elsewhere."""
    from pasim_graph.chunk_tasks import neighbours_first, pinned_to

    todo = [3, 4, 5, 6, 7, 8, 9, 10, 11, 12]
    pinned = pinned_to(neighbours_first(todo, 2), ["tcp://a", "tcp://b"])
    assert pinned == {i: ["tcp://a"] for i in (3, 4, 5, 6)} | {
        i: ["tcp://b"] for i in (8, 9, 10, 11)
    }
    slots = ["tcp://a", "tcp://a", "tcp://b"]
    three = pinned_to(neighbours_first(list(range(12)), 3), slots)
    assert three == {0: ["tcp://a"], 1: ["tcp://a"], 2: ["tcp://a"]} | {
        i: ["tcp://a"] for i in (4, 5, 6)
    } | {i: ["tcp://b"] for i in (8, 9, 10)}
    assert pinned_to({7: 0}, ["tcp://a", "tcp://b"]) == {7: ["tcp://a"]}
    assert pinned_to(neighbours_first(todo, 1), []) == {}  # no worker has joined yet
