"""Lost workers and a lost scheduler on a dask.distributed cluster (real processes, loopback).

* One of two workers killed with -9 mid-run: dask reruns its chunks elsewhere; the run
  completes with exactly the numbers of a run on this machine's threads.
* The scheduler killed with -9 mid-run: ``pasim run`` exits 2 with one line (no traceback),
  the chunks written are kept, and ``--resume`` (on this machine's threads: any cluster or
  none) completes a store identical to an uninterrupted run's.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pasim_graph.cli import main
from pasim_graph.store import run_state

from ..conftest import GRAPHS, ROOT, free_port, same_sweep

RUN = ["run", str(GRAPHS / "uniform_ideal.yaml"), "--set", "scan.azimuth_stop_deg=40"]
RUN += ["--chunk", "1", "--seed", "21"]
DASK = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
WORKER = [sys.executable, "-m", "distributed.cli.dask_worker"]


class Cluster:
    """A scheduler and two single-threaded workers, each its own process."""

    def __init__(self, logs: Path):
        self.address = f"tcp://127.0.0.1:{free_port()}"
        port = self.address.rsplit(":", 1)[1]
        env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
        self.scheduler = subprocess.Popen(
            [*DASK, "--host", "127.0.0.1", "--port", port, "--no-dashboard"],
            stdout=subprocess.DEVNULL,
            stderr=open(logs / "scheduler.log", "w"),
            env=env,
        )
        self.workers = [
            subprocess.Popen(
                [*WORKER, self.address, "--nthreads", "1", "--no-dashboard", "--name", f"w{i}"],
                stdout=subprocess.DEVNULL,
                stderr=open(logs / f"worker{i}.log", "w"),
                env=env,
            )
            for i in range(2)
        ]
        from distributed import Client

        deadline = time.monotonic() + 60
        while True:
            try:
                with Client(self.address, timeout="2s") as client:
                    if len(client.scheduler_info()["workers"]) == 2:
                        break
            except OSError:
                pass
            if time.monotonic() > deadline:
                self.close()
                pytest.skip("a local dask cluster did not start in 60 s")
            time.sleep(0.3)

    def close(self) -> None:
        for proc in [*self.workers, self.scheduler]:
            if proc.poll() is None:
                proc.kill()
            proc.wait()


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "ref.zarr"
    assert main([*RUN, "--out", str(out)]) == 0
    return out


def start_run(cluster: Cluster, out: Path) -> subprocess.Popen:
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "pasim_graph",
            *RUN,
            "--scheduler",
            cluster.address,
            "--out",
            str(out),
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline:
        state = run_state(out) if out.exists() else None
        if state is not None and 3 <= state[1].sum() < state[1].size - 10:
            return proc
        if proc.poll() is not None:
            pytest.fail(f"the run ended before the fault: {proc.communicate()[1]}")
        time.sleep(0.02)
    proc.kill()
    pytest.fail("the run wrote no chunk in 180 s")


# With -m slow: the default suite kills a worker mid-run in
# tests/execution/test_external_scheduler.py (the one holding the run's inputs, as it is given
# a chunk: the harder case, on the same loopback cluster of real processes).
@pytest.mark.slow
def test_a_killed_worker_is_survived_with_the_same_numbers(tmp_path, reference):
    cluster = Cluster(tmp_path)
    try:
        out = tmp_path / "run.zarr"
        proc = start_run(cluster, out)
        cluster.workers[0].send_signal(signal.SIGKILL)
        _, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
    finally:
        cluster.close()
    same_sweep(out, reference)


def test_a_killed_scheduler_ends_the_run_cleanly_and_resume_completes(tmp_path, reference, capsys):
    cluster = Cluster(tmp_path)
    try:
        out = tmp_path / "run.zarr"
        proc = start_run(cluster, out)
        cluster.scheduler.send_signal(signal.SIGKILL)
        _, err = proc.communicate(timeout=300)
    finally:
        cluster.close()
    assert proc.returncode == 2, err
    assert "Traceback" not in err, err
    assert "lost the connection to the scheduler" in err and "--resume" in err, err
    state = run_state(out)
    assert state is not None and state[0]["pasim_complete"] != "true"
    assert main([*RUN, "--out", str(out), "--resume"]) == 0
    same_sweep(out, reference)


def test_a_scheduler_is_lost_once_the_client_notices_within_the_wait():
    """A record fetched as the scheduler was killed failed while the client still said
    "running": the run printed a traceback. The client is given a moment to notice."""
    import threading

    from pasim_graph.chunk_tasks import scheduler_lost

    class Client:
        status = "running"

    noticing = Client()
    threading.Timer(0.2, lambda: setattr(noticing, "status", "connecting")).start()
    assert scheduler_lost(noticing, wait_s=3.0)
    assert not scheduler_lost(Client(), wait_s=0.2)  # still running: an error of its own
