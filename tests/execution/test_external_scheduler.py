"""A run and a study on an external ``dask scheduler`` with separate ``dask worker`` processes
(distributed's own command line, on loopback), against the same work done in this machine's
threads, and the check that every worker shares the store's folder before anything is written.

* ``pasim run --scheduler ADDR`` (``--out`` relative, the workers in another working
  folder: it is made absolute here): the store holds the values of a run on this machine's
  threads, bit for bit (the draws are keyed by seed, block and beam, not by where a chunk ran);
  and the same with the worker that holds the run's inputs killed (-9) as it starts a chunk.
* ``pasim study --scheduler ADDR`` (slow): every store and ``scores.json`` are the serial
  study's; and with one of the two workers killed (-9) as the first run's chunks start, or
  as soon as it is given a chunk, the study goes on on the other and ends with the same
  scores.
* A cluster whose workers do not see the folder this process writes (an empty file system
  mounted over it in their own mount namespace, ``unshare``: a stand-in for a worker on a
  machine without the shared file system) is refused before anything is written: exit 2, one
  line naming the worker and the folder.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from distributed import WorkerPlugin

from pasim_graph.cli import main
from pasim_graph.shared_storage import PREFIX, StorageError, check_shared_storage, probe_on_worker
from pasim_graph.store import run_state

from ..conftest import (
    ROOT,
    TINY_STUDY,
    TINY_UNIFORM,
    free_port,
    pasim,
    run_cli,
    same_sweep,
    store_values,
)

RUN = ["run", TINY_UNIFORM, "--set", "scan.azimuth_stop_deg=6", "--chunk", "1", "--seed", "3"]
SCHEDULER = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
WORKER = [sys.executable, "-m", "distributed.cli.dask_worker"]


class Cluster:
    """``dask scheduler`` and two single-threaded ``dask worker`` processes (no nanny: the
    process killed is the worker itself), started in ``home`` and torn down by :meth:`close`."""

    def __init__(self, home: Path, workers: int = 2, hide: Path | None = None):
        home.mkdir(parents=True, exist_ok=True)
        self.home = home
        port = free_port()
        self.address = f"tcp://127.0.0.1:{port}"
        env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
        self.procs: list[subprocess.Popen] = []
        try:
            port = self.address.rsplit(":", 1)[1]
            args = [*SCHEDULER, "--host", "127.0.0.1", "--port", port, "--no-dashboard"]
            self.procs.append(self._start(home, "scheduler", env, args))
            for i in range(workers):
                args = [*WORKER, self.address, "--nthreads", "1", "--no-nanny"]
                args += ["--no-dashboard", "--name", f"w{i}"]
                if hide is not None:
                    args = [*unshared(hide), *args]
                self.procs.append(self._start(home, f"worker{i}", env, args))
            self._wait(workers)
        except BaseException:
            self.close()
            raise

    @staticmethod
    def _start(home: Path, name: str, env: dict, args: list[str]) -> subprocess.Popen:
        return subprocess.Popen(
            args,
            cwd=home,
            stdout=subprocess.DEVNULL,
            stderr=open(home / f"{name}.log", "w"),
            env=env,
        )

    @property
    def workers(self) -> list[subprocess.Popen]:
        return self.procs[1:]

    def _wait(self, workers: int) -> None:
        from distributed import Client

        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                with Client(self.address, timeout="2s") as client:
                    if len(client.scheduler_info()["workers"]) == workers:
                        return
            except OSError:
                pass
            time.sleep(0.2)
        pytest.skip("a dask scheduler and its workers did not start in 60 s on loopback")

    def close(self) -> None:
        for proc in reversed(self.procs):
            if proc.poll() is None:
                proc.kill()
            proc.wait()
            if proc.stderr is not None:
                proc.stderr.close()


def unshared(hide: Path) -> list[str]:
    """The command prefix that runs a process in a mount namespace of its own where ``hide``
    is an empty file system (tmpfs): it sees the same path as this process, other contents."""
    script = f'mount -t tmpfs pasim-hidden {hide} && exec "$@"'
    return ["unshare", "--mount", "--propagation", "private", "sh", "-c", script, "sh"]


@pytest.fixture(scope="module")
def blind(tmp_path_factory) -> Iterator[tuple[Cluster, Path]]:
    """A cluster whose workers see an empty folder where this process sees ``folder`` (the
    second item): skipped where mount namespaces are not allowed (not root)."""
    folder = tmp_path_factory.mktemp("blind")
    try:
        probe = subprocess.run([*unshared(folder), "true"], capture_output=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        probe = None
    if probe is None or probe.returncode != 0:
        pytest.skip("unshare --mount cannot hide a folder from a worker here (needs root)")
    c = Cluster(tmp_path_factory.mktemp("blind-home"), workers=1, hide=folder)
    try:
        yield c, folder
    finally:
        c.close()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory) -> Iterator[Cluster]:
    """Started in a folder of its own: its workers' working folder is not the tests'."""
    c = Cluster(tmp_path_factory.mktemp("cluster-home"))
    try:
        yield c
    finally:
        c.close()


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("ref") / "ref.zarr"
    assert main([*RUN, "--out", str(out)]) == 0
    return out


def test_a_run_on_an_external_scheduler_is_the_local_run(
    tmp_path, cluster, reference, capsys, monkeypatch
):
    """6 chunks of 1 beam on the two workers against the same run on this process's threads
    (the independent computation): every stored value equal, bit for bit. ``--out`` is
    relative and the workers' working folder another than this process's: the path they are
    given is made absolute here."""
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "run.zarr"
    code, err = pasim(capsys, *RUN, "--scheduler", cluster.address, "--out", "run.zarr")
    assert code == 0, err
    assert not list(cluster.home.glob("*.zarr"))  # nothing where the workers started
    same_sweep(out, reference)
    # Both workers ran chunks: the work went to the cluster, not to this machine's threads.
    from pasim_graph.task_record import read_tasks

    workers = {t["worker"] for t in read_tasks(out)[-1]["tasks"]}
    assert len(workers) == 2, workers
    assert not list(tmp_path.glob(f"{PREFIX}*")), "the storage probe left its files"


class KillOnChunk(WorkerPlugin):
    """A worker plugin: the first worker that starts a chunk (``pasim-chunk-``) while holding
    the run's shared inputs (``pasim-inputs-``) kills itself (-9) before running it: the
    worker whose loss the run's inputs must survive. Decided inside the worker, at the
    transition itself (a client polling the scheduler from outside could miss it on a fast
    machine: a chunk of this run is a few tens of ms); one worker only, by creating ``claim``
    (the workers share this machine's file system), which then names it."""

    name = "pasim-test-kill-on-chunk"

    def __init__(self, claim: Path):
        super().__init__()
        self.claim = str(claim)

    def setup(self, worker) -> None:
        self.worker = worker

    def transition(self, key, start: str, finish: str, **kwargs) -> None:
        if finish != "executing" or not str(key).startswith("pasim-chunk-"):
            return
        if not any(str(k).startswith("pasim-inputs-") for k in self.worker.data):
            return
        try:
            fd = os.open(self.claim, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            return
        os.write(fd, str(self.worker.name).encode())
        os.close(fd)
        os.kill(os.getpid(), signal.SIGKILL)


def kill_on_chunk(cluster: Cluster, claim: Path) -> None:
    """Register :class:`KillOnChunk` on every worker of ``cluster`` (sent by value: the
    workers cannot import this test module)."""
    import cloudpickle
    from distributed import Client

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    try:
        # Not the process's default client: it would set dask's global scheduler.
        with Client(cluster.address, timeout="10s", set_as_default=False) as client:
            client.register_plugin(KillOnChunk(claim))
    finally:
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


def test_a_worker_killed_as_it_starts_a_chunk_is_survived(tmp_path, reference, capsys):
    """One of the two workers killed (-9) as soon as it holds the run's shared inputs and is
    given a chunk: the run completes on the other worker and its store holds the values of
    the run on this process's threads (the independent computation), bit for bit."""
    own = Cluster(tmp_path / "home")
    claim = tmp_path / "killed"
    try:
        kill_on_chunk(own, claim)
        out = tmp_path / "run.zarr"
        code, err = pasim(capsys, *RUN, "--scheduler", own.address, "--out", str(out))
        assert claim.exists(), "no worker was given a chunk while holding the inputs"
        assert code == 0, err
        assert own.workers[int(claim.read_text()[1:])].wait(30) == -signal.SIGKILL
    finally:
        own.close()
    same_sweep(out, reference)


def test_workers_that_do_not_share_the_folder_are_refused_before_anything_is_written(blind, capsys):
    """The workers see an empty file system where this process writes --out's folder (as a
    worker without the shared file system would). Refused: exit 2, one line naming a
    worker's address and the folder, and nothing written there."""
    cluster, folder = blind
    out = folder / "g.zarr"
    code, err = pasim(capsys, *RUN, "--scheduler", cluster.address, "--out", str(out))
    assert code == 2, err
    lines = [line for line in err.splitlines() if line.startswith("error")]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert "worker tcp://127.0.0.1:" in lines[0], lines[0]
    assert f"does not share the store's folder {folder}: it cannot read" in lines[0], lines[0]
    assert not list(folder.iterdir())  # no store, no probe left


def test_the_same_study_refused_before_its_folder_is_made(blind, capsys):
    cluster, folder = blind
    out = folder / "s"
    code, err = pasim(
        capsys, "study", str(TINY_STUDY), "--out", str(out), "--scheduler", cluster.address
    )
    assert code == 2, err
    assert "worker tcp://127.0.0.1:" in err and "Traceback" not in err, err
    assert not list(folder.iterdir())


class _OneWorker:
    """``client.run`` for one worker at ``seen``: the folder it reads and writes when told
    ``folder`` (the worker's own view of the path), as distributed calls it."""

    def __init__(self, seen: Path):
        self.seen = seen

    def run(self, fn, folder, token):
        class W:
            address = "tcp://10.0.0.7:40000"

        return {W.address: fn(str(self.seen), token, dask_worker=W)}


def test_a_worker_that_writes_where_this_process_does_not_see_is_refused(tmp_path):
    """The probe's second half, in this process with the worker's view monkeypatched: the
    worker reads this process's probe (a copy of it in its own folder, as a stale replica
    would hold) but its own probe does not reach this process's folder."""
    ours, theirs = tmp_path / "ours", tmp_path / "theirs"
    ours.mkdir()
    theirs.mkdir()

    class Copying(_OneWorker):
        def run(self, fn, folder, token):
            for probe in Path(folder).glob(f"{PREFIX}*"):
                (self.seen / probe.name).write_text(probe.read_text())
            return super().run(fn, folder, token)

    with pytest.raises(StorageError) as exc:
        check_shared_storage(Copying(theirs), ours)
    msg = str(exc.value)
    assert "worker tcp://10.0.0.7:40000" in msg and str(ours) in msg, msg
    assert "does not see it" in msg, msg
    assert not list(ours.iterdir())  # the probe removed


def test_a_worker_sharing_the_folder_passes_and_leaves_nothing(tmp_path):
    check_shared_storage(_OneWorker(tmp_path), tmp_path / "not" / "made" / "yet.zarr")
    assert not list(tmp_path.iterdir())


def test_a_worker_that_cannot_write_says_why(tmp_path):
    """A worker's write refused (a read-only file system, as the worker's own mount would
    be: its open() monkeypatched, since this process runs as root)."""
    (tmp_path / f"{PREFIX}tok").write_text("tok")

    def refuse(self, *a, **k):
        raise OSError(30, "Read-only file system")

    mp = pytest.MonkeyPatch()
    mp.setattr(Path, "write_text", refuse)
    try:
        problem = probe_on_worker(str(tmp_path), "tok")
    finally:
        mp.undo()
    assert problem == "cannot write there (Read-only file system)"


def same_study(out: Path, study: Path) -> None:
    """Every store of ``out`` holds the values of the serial study's (``study``), its
    scores.json is the same file, and the antenna and hardware measurements its manifest
    keeps (tasks on the workers, which run in a folder of their own here) are the same."""
    stores = sorted(p.relative_to(study) for p in (study / "runs").rglob("*.zarr"))
    assert stores == sorted(p.relative_to(out) for p in (out / "runs").rglob("*.zarr"))
    for rel in stores:
        ours, theirs = store_values(out / rel), store_values(study / rel)
        assert ours.keys() == theirs.keys(), rel
        for name in theirs:
            kind = theirs[name].dtype.kind
            assert np.array_equal(ours[name], theirs[name], equal_nan=kind in "fc"), (rel, name)
    assert (out / "scores.json").read_text() == (study / "scores.json").read_text()
    ours_m = json.loads((out / "pasim-study.json").read_text())
    theirs_m = json.loads((study / "pasim-study.json").read_text())
    for key in ("beamwidths", "patterns", "hardware"):
        assert theirs_m.get(key) and ours_m.get(key) == theirs_m.get(key), key


STUDY = ["study", str(TINY_STUDY), "--no-report"]


@pytest.mark.slow
def test_the_tiny_study_on_an_external_scheduler_is_the_serial_study(tmp_path, cluster, tiny_study):
    """The tiny study's 8 runs (several in flight) on the two workers against the serial
    study run in one process (the tiny_study fixture): the same values and scores.json."""
    out = tmp_path / "out"
    res = run_cli(*STUDY, "--out", str(out), "--scheduler", cluster.address)
    assert res.returncode == 0, res.stderr
    same_study(out, tiny_study)


def _study(out: Path, address: str) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "pasim_graph", *STUDY, "--out", str(out)]
    return subprocess.Popen(
        [*cmd, "--scheduler", address],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _laid_out(path: Path) -> bool:
    try:
        return run_state(path) is not None
    except Exception:
        return False  # a store half made: not yet


@pytest.mark.slow
def test_a_worker_killed_mid_study_is_survived_with_the_same_scores(tmp_path, tiny_study):
    """One of the two workers killed (-9) as the first run's chunks start (its store laid
    out): the study goes on on the other worker and completes with the serial study's values
    and scores."""
    own = Cluster(tmp_path / "home")
    try:
        out = tmp_path / "out"
        proc = _study(out, own.address)
        deadline = time.monotonic() + 300
        while not any(_laid_out(p) for p in (out / "runs").rglob("*.zarr")):
            if proc.poll() is not None or time.monotonic() > deadline:
                proc.kill()
                pytest.fail(f"no run was laid out: {proc.communicate()[1][-4000:]}")
            time.sleep(0.05)
        own.workers[0].send_signal(signal.SIGKILL)
        _, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err[-4000:]
        assert own.workers[0].wait() == -signal.SIGKILL
    finally:
        own.close()
    same_study(out, tiny_study)


@pytest.mark.slow
def test_a_worker_killed_while_it_holds_a_chunk_is_survived(tmp_path, tiny_study):
    """One of the two workers killed (-9) as soon as the scheduler has given it a chunk:
    dask should rerun that chunk on the other worker and the study complete with the
    serial study's values and scores."""
    from distributed import Client

    own = Cluster(tmp_path / "home")
    try:
        out = tmp_path / "out"
        proc = _study(out, own.address)
        with Client(own.address, timeout="10s") as watch:
            workers = watch.scheduler_info()["workers"]
            w0 = next(a for a, w in workers.items() if w["name"] == "w0")
            deadline = time.monotonic() + 300
            while not watch.processing(workers=[w0]).get(w0):
                if proc.poll() is not None or time.monotonic() > deadline:
                    proc.kill()
                    pytest.fail(f"w0 was given no chunk: {proc.communicate()[1][-4000:]}")
                time.sleep(0.02)
        own.workers[0].send_signal(signal.SIGKILL)
        try:
            _, err = proc.communicate(timeout=150)  # the whole study: 45-115 s here
        except subprocess.TimeoutExpired:
            proc.kill()
            raise
        assert proc.returncode == 0, err[-4000:]
    finally:
        own.close()
    same_study(out, tiny_study)
