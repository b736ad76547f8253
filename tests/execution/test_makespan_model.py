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
    """A one-worker study of two runs (made up): each run's set-up steps (load, layout) are the
    `pasim` process's lane, its tasks the workers' work; the cluster's connection and the chunk
    phase (a step spanning the tasks) are not counted again. Work 2 x 3 x 2 = 12 s, set-ups
    2 x (0.5 + 1.5) = 4 s; 20 s of wall leave a rest of 8 s (no start time recorded: the
    residual); 30 s of CPU, 22 beside the work: 2 workers on 2 cores, 8 + max(6, 4, 11)."""
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
    assert model == {
        "work_s": 12.0,
        "setup_s": 4.0,
        "process_s": 0.0,  # a row from before the study recorded its process
        "figures_s": 0.0,
        "figures": 0,
        "rest_s": 8.0,
        "beside_cpu_s": 22.0,
        "start_cpu_s": 0.0,  # a record from before the workers' CPU was kept
        "runs": [(0, 0.0), (0, 0.0)],  # no beams recorded, and no first use
    }
    assert bench.predict_study(model, 2, 2) == 19.0
    # The runs' set-ups bound it from below, however many workers share the work.
    assert bench.predict_study(model, 100) == 8.0 + 4.0


def test_the_study_s_rest_is_what_no_run_overlaps(bench):
    """With the study's start known (``began``, or its end ``date`` less its wall time), the
    rest is the time before the first run began and after the last one's last chunk, less the
    report's figures: here 3 s before, 20 - 14 - 2 = 4 s after. (The residual, wall less work,
    set-ups and figures, would be nil: on one worker the set-ups overlap the chunks.)"""
    runs = [
        {"started": 1000.0 + 3.0 + 5.0 * k, "stopped": 6.0, "steps": [], "tasks": []}
        for k in range(2)
    ]
    row = {"records": runs, "wall_s": 20.0, "cpu_s": 20.0, "figures_s": 2.0, "began": 1000.0}
    assert bench.study_model(row)["rest_s"] == 7.0
    dated = {k: v for k, v in row.items() if k != "began"} | {"date": "2026-11-29T08:35:15Z"}
    ended = 1795941315.0  # that date, in epoch seconds
    for run in runs:
        run["started"] += ended - 1020.0
    assert bench.study_model(dated)["rest_s"] == pytest.approx(7.0)


def test_a_study_s_figures_on_several_workers_took_their_share_of_its_tail(bench):
    """The report's figures are drawn on every worker at once: on two, 2 s of drawing (of 4
    figures) took 1 s of the tail, and the rest after the last chunk is 4 - 1 = 3 s, not
    4 - 2 (the model predicts the figures spread over the workers the same way)."""
    runs = [{"started": 1003.0, "stopped": 13.0, "steps": [], "tasks": []}]
    row = {"records": runs, "wall_s": 20.0, "cpu_s": 30.0, "figures_s": 2.0, "began": 1000.0}
    assert bench.study_model({**row, "workers": 2, "figures": 4})["rest_s"] == 3.0 + 3.0
    assert bench.study_model({**row, "workers": 1, "figures": 4})["rest_s"] == 3.0 + 2.0
    assert bench.study_model({**row, "workers": 8, "figures": 1})["rest_s"] == 3.0 + 2.0


def test_a_run_reaching_more_workers_pays_its_first_use_on_each(bench):
    """A run of 90 beams in 9 chunks whose first took 1 s more than the others (its prepared
    inputs): on 4 workers its chunks (as many as the chunking chosen for 4 gives, at least 4)
    reach every worker, 3 of which pay that second again; on 1000 they reach as many workers
    as there are chunks. The CPU grows by as much, and the busy share counts it."""
    run = {
        "steps": [],
        "tasks": [
            {
                "start": 2.0 * i,
                "stop": 2.0 * i + (3.0 if i == 0 else 2.0),
                "beams": [10 * i, 10 * i + 10],
            }
            for i in range(9)
        ],
    }
    model = bench.study_model({"records": [run], "wall_s": 20.0, "cpu_s": 20.0})
    assert model["runs"] == [(90, 1.0)]
    assert bench.first_uses(model, 1) == 0.0
    assert bench.first_uses(model, 4) == 3.0
    chunks = -(-90 // bench.choose_chunk(90, 1000))
    assert bench.first_uses(model, 1000) == chunks - 1
    # Work 19 s (1 s rest); on 4 workers: 1 + max(19 + 3, 19 + 3) / 4.
    assert bench.predict_study(model, 4) == pytest.approx(1.0 + 22.0 / 4)
    assert bench.study_busy(model, 4) == pytest.approx((20.0 + 3.0) / (4 * (1.0 + 22.0 / 4)))


def test_the_study_model_spreads_measurements_and_figures(bench):
    """Two runs of 0.5 s of set-up and 3 x 2 s of tasks, 2 s of antenna measurements (tasks
    beside the runs: work) and a report of 3 figures drawn in 3 s (tasks after the runs), in
    25 s of wall and 35 s of CPU: work 2 x 6 + 2 = 14, set-ups 1, rest 25 - 14 - 3 = 8, beside
    35 - 8 - 3 = 24. On 2 workers and cores: 8 + max(7, 1, 12) + 3 / 2; on 16, a core each:
    8 + max(14 / 16, 1, 24 / 16) + 3 / 3 (no more than one worker a figure)."""
    run = {
        "steps": [{"kind": "load", "start": 0.0, "stop": 0.5}],
        "tasks": [{"start": 3.0 + 2 * i, "stop": 5.0 + 2 * i} for i in range(3)],
    }
    row = {"records": [run, run], "wall_s": 25.0, "cpu_s": 35.0, "measure_s": 2.0}
    model = bench.study_model({**row, "figures": 3, "figures_s": 3.0})
    assert model["work_s"] == 14.0 and model["setup_s"] == 1.0
    assert model["rest_s"] == 8.0 and model["beside_cpu_s"] == 24.0
    assert bench.predict_study(model, 2, 2) == pytest.approx(8.0 + 12.0 + 1.5)
    assert bench.predict_study(model, 16) == pytest.approx(8.0 + 24.0 / 16 + 1.0)
    # The report line and the measurement lines the study prints are what the benchmark reads.
    err = (
        "measured the antenna of a/b/-: 1.5 s\nmeasured the hardware of a: 0.5 s\n"
        "wrote /x/report.html in 4.2 s (15 figures, 5.6 s of drawing on the cluster)\n"
    )
    assert sum(float(x) for x in bench.MEASURED.findall(err)) == 2.0
    assert bench.REPORTED.search(err).groups() == ("4.2", "15", "5.6")


def test_fitted_on_several_runs_each_term_is_their_median(bench):
    # Three one-worker runs: two alike, one whose first chunk paid 2 s more (a noisy first
    # use): the fit follows the two, for every beam and every term.
    runs = [
        {"record": record(1.0, first_use=0.5), "wall_s": 8 * 1.1 + 5.5},
        {"record": record(1.0, first_use=0.5), "wall_s": 8 * 1.1 + 5.5},
        {"record": record(1.0, first_use=2.5), "wall_s": 8 * 1.1 + 7.5},
    ]
    fitted = bench.fit_graph_model(runs)
    alone = bench.graph_model(runs[0])
    assert fitted["runs"] == 3 and fitted["costs"] == pytest.approx(alone["costs"])
    for term in ("first_use_s", "fixed_s", "write_s", "phase_cpu_s", "beam_s"):
        assert fitted[term] == pytest.approx(alone[term]), term
    assert bench.predict(fitted, 2)["chunks_s"] == pytest.approx(4 * 1.1 + 0.5)


def test_every_further_worker_pays_a_worker_s_start_again(bench):
    """The one worker of a study (made up) had used 3 s of CPU when its first task began (its
    imports, warm-up, the first inputs) and more at each later one: that 3 s is what starting
    a worker costs, paid again by each further worker. Work 12 s, rest 2 s, 12 s of CPU beside
    the work: on 2 workers and 2 cores 2 + (12 + 3) / 2."""
    run = {
        "steps": [],
        "tasks": [
            {"start": 4.0 * i, "stop": 4.0 * i + 4.0, "worker": "h:1", "worker_cpu_s": 3.0 + 4 * i}
            for i in range(3)
        ],
    }
    model = bench.study_model({"records": [run], "wall_s": 14.0, "cpu_s": 14.0})
    assert model["start_cpu_s"] == 3.0 and model["beside_cpu_s"] == 12.0
    assert bench.predict_study(model, 1, 1) == pytest.approx(14.0)
    assert bench.predict_study(model, 2, 2) == pytest.approx(2.0 + 15.0 / 2)
    assert bench.study_busy(model, 2) == pytest.approx((2.0 + 12.0 + 3.0) / (2 * (2.0 + 15.0 / 2)))


def test_the_pasim_process_s_cpu_while_the_runs_ran_is_a_lane_of_its_own(bench):
    """The `pasim` process set the runs up and served the cluster with 9 s of CPU while they
    ran (made up: the study's record, two invocations, 6 + 3 s): however many workers share
    the 12 s of work, the runs take at least those 9 s."""
    run = {
        "steps": [],
        "tasks": [{"start": 4.0 * i, "stop": 4.0 * i + 4.0} for i in range(3)],
    }
    process = [{"cpu_s": 6.0, "workers": 1}, {"cpu_s": 3.0, "workers": 1}]
    row = {"records": [run], "wall_s": 14.0, "cpu_s": 14.0, "process": process}
    model = bench.study_model(row)
    assert model["process_s"] == 9.0
    assert bench.predict_study(model, 1, 1) == pytest.approx(2.0 + 12.0)
    assert bench.predict_study(model, 4, 4) == pytest.approx(2.0 + 9.0)  # not 2 + 12 / 4


def test_a_worker_s_start_leaves_out_the_measurements_it_ran_first(bench):
    """The study's antenna and hardware measurements are tasks sent to one worker each: the
    one a worker ran before its first chunk is work (counted once), not part of starting it.
    Made up: worker h:1 had 3 s of CPU at its first chunk (epoch 104 s), 1.2 s of it a
    measurement that ended at 102 s; its measurement ending at 110 s came later. Worker h:2
    ran none: 1.5 s. The start is their median, (1.8 + 1.5) / 2."""
    run = {
        "started": 100.0,
        "steps": [],
        "tasks": [
            {
                "start": 4.0,
                "stop": 8.0,
                "worker": "h:1/Dask-Default-Threads-1-0",
                "worker_cpu_s": 3.0,
            },
            {
                "start": 5.0,
                "stop": 9.0,
                "worker": "h:2/Dask-Default-Threads-2-0",
                "worker_cpu_s": 1.5,
            },
        ],
    }
    measured = [
        {"kind": "patterns", "start": 100.8, "stop": 102.0, "cpu_s": 1.2, "worker": "h:1"},
        {"kind": "hardware", "start": 109.0, "stop": 110.0, "cpu_s": 1.0, "worker": "h:1"},
    ]
    row = {"records": [run], "wall_s": 14.0, "cpu_s": 14.0, "measurements": measured}
    assert bench.study_model(row)["start_cpu_s"] == pytest.approx((1.8 + 1.5) / 2)
    # Without the study's record of its measurements, the worker's CPU as it was.
    row["measurements"] = []
    assert bench.study_model(row)["start_cpu_s"] == pytest.approx((3.0 + 1.5) / 2)


def test_a_run_s_first_use_is_what_its_leading_chunks_took_beyond_a_typical_one(bench):
    # Memos filled over the first three chunks (1.5, 1.0, 0.6 against a typical 0.2), then a
    # chunk of more weather later (0.9): the first use is 1.3 + 0.8 + 0.4, not the later one.
    spans = [1.5, 1.0, 0.6, 0.2, 0.1, 0.2, 0.9, 0.2, 0.2]
    assert bench.leading_excess(spans) == pytest.approx(2.5)
    assert bench.leading_excess([0.1, 0.3, 0.2]) == 0.0  # a first chunk below typical
    assert bench.leading_excess([2.0]) == 0.0


def test_a_baseline_checkout_on_the_path_alone_is_refused(bench, tmp_path):
    """A checkout's block library (``blocks/``) is found as ``pasim_blocks`` only through an
    install: a baseline given by PYTHONPATH alone would run this build's blocks, so the
    benchmark names the package that would come from elsewhere."""
    import sys

    checkout = tmp_path / "checkout"
    for package in ("pasim_graph", "blocks"):
        (checkout / package).mkdir(parents=True)
        (checkout / package / "__init__.py").write_text("")
    import pasim_blocks

    message = bench.foreign_packages(sys.executable, str(checkout))
    assert pasim_blocks.__file__ in message and "pasim_graph" not in message
    assert "--baseline-python" in message
    (checkout / "pasim_blocks").mkdir()
    (checkout / "pasim_blocks" / "__init__.py").write_text("")
    assert bench.foreign_packages(sys.executable, str(checkout)) == ""


def test_the_cost_of_a_file_is_measured_where_the_stores_go(bench, tmp_path):
    """Each graph run's row carries the CPU a small file cost in its store's folder just
    before it: milliseconds (os.times counts in ticks: 0 for a fast disk and few files), and
    the probe leaves nothing behind."""
    cost = bench.file_cost_ms(tmp_path, files=40)
    assert 0 <= cost < 1000
    assert list(tmp_path.iterdir()) == []
