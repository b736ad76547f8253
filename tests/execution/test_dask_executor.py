"""The Dask executor: the same numbers at any chunking and worker count; resumable runs."""

from __future__ import annotations

import numpy as np
import xarray as xr

from pasim_graph.dask_executor import choose_chunk
from pasim_graph.store import run_state
from pasim_graph.task_record import read_tasks

from ..conftest import GRAPHS, kill_run_part_way, pasim_result, run_cli

GENERIC = str(GRAPHS / "generic_radar.yaml")
FAST = ["--set", "scan.pulses=16", "--seed", "5"]


def sweep(path):
    return xr.open_datatree(path, engine="zarr")["sweep_0"].to_dataset()


def assert_same_numbers(a, b):
    floats = [v for v in a.data_vars if a[v].dtype.kind in "fc"]
    assert len(floats) >= 19  # six moments, six truths, six errors, SNR, ...
    for name in floats:
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    np.testing.assert_array_equal(a["azimuth"].values, b["azimuth"].values)


def test_chunk_size_and_workers_do_not_change_the_numbers(tmp_path):
    """16 deg sector: chunks of 1 beam on one thread vs chunks of 5 on a 2-worker cluster."""
    one = tmp_path / "one.zarr"
    res = run_cli(
        "run",
        GENERIC,
        "--sector",
        "270:286",
        *FAST,
        "--chunk",
        "1",
        "--out",
        str(one),
        env={"DASK_NUM_WORKERS": "1"},
    )
    assert res.returncode == 0, res.stderr
    two = tmp_path / "two.zarr"
    res = run_cli(
        "run",
        GENERIC,
        "--sector",
        "270:286",
        *FAST,
        "--chunk",
        "5",
        "--workers",
        "2",
        "--out",
        str(two),
    )
    assert res.returncode == 0, res.stderr
    a, b = sweep(one), sweep(two)
    assert a.sizes["azimuth"] == 16
    assert_same_numbers(a, b)
    # The store is chunked along azimuth as asked.
    assert b["DBZH"].encoding["chunks"][0] == 5
    # The executor kept a record of the run's tasks with the store: every chunk, once, on
    # one of the two workers, with its times and bytes; the set-up steps in this process.
    (record,) = read_tasks(two)
    assert record["workers"] == 2 and record["chunk_beams"] == 5
    tasks = record["tasks"]
    assert sorted(t["index"] for t in tasks) == list(range(4))
    assert len({t["worker"] for t in tasks}) <= 2
    for t in tasks:
        assert t["kind"] == "chunk" and 0 <= t["start"] <= t["computed"] <= t["stop"]
        assert t["bytes"] > 0 and t["cpu_s"] > 0
        # The worker process's CPU while the task ran holds its thread's (and its writes').
        assert t["process_cpu_s"] >= t["cpu_s"]
    steps = {s["kind"]: s for s in record["steps"]}
    assert {"load", "static", "layout", "connect", "chunks"} <= set(steps)
    # The chunk phase begins when the cluster is up and the store laid out.
    assert steps["chunks"]["start"] >= max(steps["connect"]["stop"], steps["layout"]["stop"])
    # A store one beam at a time on one thread records its 16 tasks.
    assert len(read_tasks(one)[0]["tasks"]) == 16


def test_chunk_chosen_from_the_workers():
    """Without --chunk: at most 8 beams, the fewest rounds of tasks over the workers."""
    assert choose_chunk(360, 1) == 8
    assert choose_chunk(360, 2) == 8
    assert choose_chunk(180, 16) == 6  # 30 tasks in 2 rounds of 7, not 23 in 2 of 9
    assert choose_chunk(3, 16) == 1
    assert choose_chunk(1, 4) == 1
    for n in range(1, 200, 7):
        for w in (1, 2, 3, 16, 64):
            assert 1 <= choose_chunk(n, w) <= 8


def test_killed_run_resumes_to_the_same_numbers(tmp_path, capsys):
    """SIGKILL part-way, then --resume: equal to a run never interrupted."""
    args = ["run", GENERIC, "--sector", "280:300", *FAST, "--chunk", "2"]
    killed = tmp_path / "killed.zarr"
    kill_run_part_way(args, killed, limit_s=120)
    state = run_state(killed)
    assert state is not None and state[0]["pasim_complete"] == "false"
    assert 0 < state[1].sum() < state[1].size

    # An incomplete store is never scored as if it were complete, nor silently reused.
    res = pasim_result(capsys, "score", str(killed))
    assert res.returncode == 2 and "did not finish" in res.stderr
    res = pasim_result(capsys, *args, "--out", str(killed))
    assert res.returncode == 2 and "--resume" in res.stderr

    # Resumed without --chunk: the store keeps the chunking it was begun with.
    res = pasim_result(capsys, *args[:-2], "--out", str(killed), "--resume")
    assert res.returncode == 0, res.stderr
    assert "chunks of 2" in res.stderr
    full = tmp_path / "full.zarr"
    res = pasim_result(capsys, *args, "--out", str(full))
    assert res.returncode == 0, res.stderr
    assert_same_numbers(sweep(killed), sweep(full))
    assert run_state(killed)[0]["pasim_complete"] == "true"


def test_resume_refuses_a_store_from_another_run(tmp_path, capsys):
    out = tmp_path / "a.zarr"
    res = pasim_result(capsys, "run", GENERIC, "--sector", "280:282", *FAST, "--out", str(out))
    assert res.returncode == 0, res.stderr
    res = pasim_result(
        capsys,
        "run",
        GENERIC,
        "--sector",
        "280:282",
        "--set",
        "scan.pulses=16",
        "--seed",
        "6",
        "--resume",
        "--out",
        str(out),
    )
    assert res.returncode == 2 and "another run" in res.stderr
    res = pasim_result(
        capsys, "run", GENERIC, "--sector", "280:282", *FAST, "--resume", "--out", str(out)
    )
    assert res.returncode == 0 and "already complete" in res.stderr


def test_chunk_keys_name_the_store_as_well_as_the_run():
    # A cluster runs a key once for whoever asks first: two runs of one run key (a study's
    # reference runs that several points share) in flight at once into two stores must not
    # share their chunks' keys, or the second store is never written.
    from pasim_graph.dask_executor import chunk_key

    assert chunk_key("k", "/a/run.zarr", 3) == chunk_key("k", "/a/run.zarr", 3)
    assert chunk_key("k", "/a/run.zarr", 3) != chunk_key("k", "/b/run.zarr", 3)
    assert chunk_key("k", "/a/run.zarr", 3) != chunk_key("k", "/a/run.zarr", 4)


def test_runs_sharing_a_client_set_up_one_at_a_time(tmp_path, monkeypatch):
    """A study's runs in flight share one client and set up in the `pasim` process, whose one
    interpreter N set-ups at once would share, all ending when the last does (17 runs in
    flight on 16 workers): each set-up is whole, one at a time (SETTING_UP). Two runs of the
    tiny study's graph started together in two threads on one cluster: their set-ups (a
    truth read made to take 0.3 s) do not overlap, and both runs finish."""
    import threading
    import time

    import pytest

    distributed = pytest.importorskip("distributed")
    from pasim_graph import load
    from pasim_graph.dask_executor import DaskExecutor
    from pasim_graph.executor import LocalExecutor, RunOptions

    from ..conftest import FIXTURES

    spans: list[tuple[float, float]] = []
    load_truth = LocalExecutor.load

    def slow_load(self):
        t0 = time.monotonic()
        load_truth(self)
        time.sleep(0.3)
        spans.append((t0, time.monotonic()))

    monkeypatch.setattr(LocalExecutor, "load", slow_load)
    graph = load(FIXTURES / "study" / "small_pencil.yaml")
    with distributed.Client(
        processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None
    ) as client:
        runs = [
            DaskExecutor(graph, RunOptions(seed=k, chunk_beams=4), client=client) for k in (0, 1)
        ]
        threads = [
            threading.Thread(target=run.run, args=(tmp_path / f"{k}.zarr", {}))
            for k, run in enumerate(runs)
        ]
        for t in threads:
            t.start()
        for t in threads:
            t.join(120)
    assert len(spans) == 2
    (_, first_end), (second_start, _) = sorted(spans)
    assert first_end <= second_start, spans
    for k in (0, 1):
        assert run_state(tmp_path / f"{k}.zarr")[0].get("pasim_complete") == "true"
