"""The makespan model of ``benchmarks/bench_scaling.py`` on task records made up here, where the
answer is known by hand: the chunks scheduled as dask does, each worker's first chunk paying
the first-use cost, and never faster than the machine's cores can give the phase's CPU."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

BENCH = Path(__file__).parents[2] / "benchmarks" / "bench_scaling.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_scaling", BENCH)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def record(process_cpu_share: float, first_use: float = 0.0) -> dict:
    """One worker, 8 chunks of 8 beams: 1 s of compute (its thread busy) and 0.1 s of write
    each, the first chunk ``first_use`` more; the worker process's CPU while a task ran is
    ``process_cpu_share`` of its thread's (the zarr threads writing it)."""
    tasks, t = [], 0.0
    for i in range(8):
        compute = 1.0 + (first_use if i == 0 else 0.0)
        tasks.append(
            {
                "index": i,
                "beams": [8 * i, 8 * i + 8],
                "start": t,
                "computed": t + compute,
                "stop": t + compute + 0.1,
                "cpu_s": compute,
                "process_cpu_s": compute * process_cpu_share,
                "worker": "host:1",
            }
        )
        t += compute + 0.1
    steps = [{"kind": "chunks", "start": 0.0, "stop": t, "cpu_s": 0.0}]
    return {"tasks": tasks, "steps": steps, "chunk_beams": 8}


def test_with_a_core_a_worker_the_schedule_decides(bench):
    model = bench.graph_model({"record": record(1.0), "wall_s": 8 * 1.1 + 5.0})
    assert model["fixed_s"] == pytest.approx(5.0)
    two = bench.predict(model, 2)  # a core a worker
    assert two["chunk"] == 8 and two["chunks_s"] == pytest.approx(4 * 1.1)


def test_each_worker_pays_the_first_use_once(bench):
    model = bench.graph_model({"record": record(1.0, first_use=0.5), "wall_s": 8 * 1.1 + 5.5})
    assert model["first_use_s"] == pytest.approx(0.5)
    assert bench.predict(model, 1)["chunks_s"] == pytest.approx(8 * 1.1 + 0.5)
    # Two workers: four chunks each, both paying it.
    assert bench.predict(model, 2)["chunks_s"] == pytest.approx(4 * 1.1 + 0.5)


def test_two_workers_on_two_cores_cannot_beat_the_cpu_they_need(bench):
    # The worker process burns 1.5 s of CPU for each second of its chunk's thread: on two
    # cores, two workers need 8 x 1.5 = 12 s of CPU, 6 s of wall, not the 4.4 s scheduled.
    model = bench.graph_model({"record": record(1.5), "wall_s": 8 * 1.1 + 5.0})
    on_two = bench.predict(model, 2, cores=2)
    assert on_two["scheduled_s"] == pytest.approx(4 * 1.1)
    assert on_two["chunks_s"] == pytest.approx(6.0)
    assert bench.predict(model, 2)["chunks_s"] == pytest.approx(6.0)  # a core each: the same
    assert bench.predict(model, 4, cores=4)["chunks_s"] == pytest.approx(3.0)


def test_the_study_model_counts_set_up_steps_and_tasks_once(bench):
    """A one-worker study of two runs (made up): each run's set-up steps (load, layout) and its
    tasks are the work; the cluster's connection and the chunk phase (a step spanning the
    tasks) are not counted again. Work 2 x (0.5 + 1.5 + 3 x 2) = 16 s; 20 s of wall leave a
    rest of 4 s; 30 s of CPU, 26 beside the work: 2 workers on 2 cores, 4 + max(8, 13)."""
    run = {
        "steps": [
            {"kind": "load", "start": 0.0, "stop": 0.5},
            {"kind": "connect", "start": 0.0, "stop": 3.0},
            {"kind": "layout", "start": 0.5, "stop": 2.0},
            {"kind": "chunks", "start": 3.0, "stop": 9.0},
        ],
        "tasks": [{"start": 3.0 + 2 * i, "stop": 5.0 + 2 * i} for i in range(3)],
    }
    model = bench.study_model({"records": [run, run], "wall_s": 20.0, "cpu_s": 30.0})
    assert model == {"work_s": 16.0, "rest_s": 4.0, "beside_cpu_s": 26.0}
    assert bench.predict_study(model, 2, 2) == 17.0
