"""What a local cluster and the ``pasim`` process cost at their ends and beginnings.

A study's rest (what no run overlaps: its start before the first run, its end after the last
chunk) is the part more workers cannot shorten (docs/scaling.md). Three parts of it:
the exit of every worker process and of ``pasim`` (the interpreter's last collections walk
every object left: 0.4 s each), and the cluster's start, which a study now overlaps with its
sizing and planning.
"""

from __future__ import annotations

import gc
import threading

import pasim_graph.cluster as cluster_module
from pasim_graph import cli
from pasim_graph.cluster import open_client

from ..conftest import pasim, tiny_study_file


def test_the_program_exits_with_its_objects_frozen(monkeypatch):
    monkeypatch.setattr(cli, "main", lambda: 3)
    try:
        assert cli.program() == 3
        assert gc.get_freeze_count() > 0  # the interpreter's exit will not collect them
    finally:
        gc.unfreeze()


def test_a_local_clusters_workers_freeze_their_objects_as_they_close():
    client, cluster = open_client(1, None)
    try:

        def teardown(dask_worker):
            import gc

            plugin = dask_worker.plugins["pasim-freeze-at-close"]
            before = gc.get_freeze_count()
            plugin.teardown(dask_worker)
            frozen = gc.get_freeze_count()
            gc.unfreeze()
            return before, frozen

        ((before, frozen),) = client.run(teardown).values()
        assert before == 0 and frozen > 0
    finally:
        client.close()
        cluster.close()


class Closed:
    def __init__(self, log: list[str], name: str):
        self.log, self.name = log, name

    def close(self) -> None:
        self.log.append(f"{self.name} closed")


def test_a_studys_cluster_starts_while_it_is_planned_and_closes_when_refused(
    tmp_path, capsys, monkeypatch
):
    """--workers: the cluster is started before the study is sized and planned, in a thread,
    and closed when the study is refused after all (here its --out is a file)."""
    import pasim_blocks.study.plan as plan

    log: list[str] = []
    opening = threading.Event()

    def open_client(workers, scheduler):
        assert (workers, scheduler) == (1, None)
        log.append("cluster starting")
        opening.set()
        return Closed(log, "client"), Closed(log, "cluster")

    planned = plan.plan_runs

    def plan_runs(study):
        log.append(f"planning, cluster started: {opening.wait(10)}")
        return planned(study)

    monkeypatch.setattr(cluster_module, "open_client", open_client)
    monkeypatch.setattr(plan, "plan_runs", plan_runs)
    study = tiny_study_file(tmp_path, "[0]")
    (out := tmp_path / "a file").write_text("not a study's folder")
    code, err = pasim(capsys, "study", str(study), "--out", str(out), "--workers", "1")
    assert code != 0 and "exists and is not a folder" in err, err
    assert log == [
        "cluster starting",
        "planning, cluster started: True",
        "client closed",
        "cluster closed",
    ]
