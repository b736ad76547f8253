"""A worker's warm-up pays for the modules its chunks use: after it, the first chunk of a run
imports nothing more.

Measured as a worker meets a run: the run's inputs made by ``pasim run`` in one process and
handed, pickled, to a fresh one, which warms up for the run's per-chunk blocks
(``warm_up_here``, what every worker runs when it starts) and runs the first chunk. Before,
the 2 m CPPAR's first chunk imported scipy.signal and 420 modules with it (0.55 s of CPU in
each worker), the ring array's too, the planar array its coupling module, and every graph's
the package-metadata reader and an xarray module.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from ..conftest import ROOT

MAKE_INPUTS = """
import pickle, sys
import pasim_graph.dask_executor as executor

def keep(sweeps, todo, keys, starts, static, path, attrs, **options):
    with open(sys.argv[1], "wb") as f:
        pickle.dump((sweeps[0].for_chunks(), starts, static, path, attrs), f)
    raise SystemExit(0)

executor.compute_local = keep
from pasim_graph.cli import main
main(["run", sys.argv[2], "--sector", "250:254", "--out", sys.argv[3], "--scheduler", "sync"])
"""

FIRST_CHUNK = """
import json, pickle, sys
with open(sys.argv[1], "rb") as f:
    sweep, starts, static, path, attrs = pickle.load(f)
from pasim_graph.chunk_tasks import run_and_write
from pasim_graph.cluster import warm_up_here
warm_up_here([type(sweep.plan.blocks[name]) for name in sweep.plan.per_chunk])
before = set(sys.modules)
run_and_write(sweep, static, starts[0][1], 0, path, attrs)
print(json.dumps(sorted(set(sys.modules) - before)))
"""


@pytest.mark.parametrize(
    "graph", ["generic_radar", "cppar2_radar", "ring_array", "planar_patch_radar"]
)
def test_after_the_warm_up_a_first_chunk_imports_nothing(tmp_path, graph):
    inputs, out = tmp_path / "inputs.pkl", tmp_path / "run.zarr"
    made = subprocess.run(
        [
            sys.executable,
            "-c",
            MAKE_INPUTS,
            str(inputs),
            str(ROOT / "graphs" / f"{graph}.yaml"),
            str(out),
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert made.returncode == 0 and inputs.is_file(), made.stderr[-2000:]
    ran = subprocess.run(
        [sys.executable, "-c", FIRST_CHUNK, str(inputs)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert ran.returncode == 0, ran.stderr[-2000:]
    assert json.loads(ran.stdout.splitlines()[-1]) == []


def test_a_warm_up_sent_ahead_never_holds_up_nor_fails_the_caller(monkeypatch):
    """A study sends each block class's warm-up without waiting. The scheduler sends it to
    every worker it knows, and one just killed it tried to reach for 30 s, after which the
    call failed: from the study's main thread, that held up its next run and then ended the
    study (tests/execution/test_external_scheduler.py, a worker killed mid-study, failed
    one time in two). Sent from a thread of its own, a call that blocks, then fails, is the
    caller's concern neither way."""
    import threading

    from pasim_graph.cluster import warm_up_workers

    release, called, ended = threading.Event(), threading.Event(), threading.Event()
    raised: list[BaseException] = []
    monkeypatch.setattr(threading, "excepthook", lambda args: raised.append(args.exc_value))

    class LostWorker:
        def run(self, function, classes, wait=True):
            called.set()
            release.wait(10)
            ended.set()
            raise OSError("Timed out trying to connect to tcp://127.0.0.1:1 after 30 s")

    warm_up_workers(LostWorker(), [], wait=False)  # returns while the call is blocked
    assert called.wait(10) and not ended.is_set()
    release.set()
    assert ended.wait(10)
    for thread in threading.enumerate():
        if thread.name == "pasim-warm-up":
            thread.join(10)
    assert not raised
