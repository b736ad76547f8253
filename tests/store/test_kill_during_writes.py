"""A run killed with -9 at any file write, the store's layout and its final write included,
leaves a store that ``--resume`` completes, identical to an uninterrupted run's, with its
metadata consolidated.

The kill is made where a file of the store is written (zarr's ``zarr.storage._local._put``:
the layout, metadata and consolidation; ``pasim_graph.store.writes.put_file``: the chunk files
and their done flags): a child process exits with ``os._exit(137)`` (what -9 leaves: no
cleanup, no flush) at its N-th write.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from pasim_graph.cli import main
from pasim_graph.store import MARKER, run_state

from ..conftest import GRAPHS, ROOT

RUN = ["run", str(GRAPHS / "uniform_ideal.yaml"), "--set", "scan.azimuth_stop_deg=8"]
RUN += ["--set", "scan.pulses=16", "--chunk", "2", "--seed", "9"]

CHILD = """
import os, sys
import zarr.storage._local as z
import pasim_graph.store.writes as w
n, kill_at = [0], int(sys.argv[1])
def killing(real):
    def put(*a, **k):
        n[0] += 1
        if n[0] == kill_at:
            os._exit(137)
        return real(*a, **k)
    return put
z._put, w.put_file = killing(z._put), killing(w.put_file)
if kill_at == 0:
    import atexit
    atexit.register(lambda: print(n[0], file=sys.stderr))
from pasim_graph.cli import main
sys.exit(main(sys.argv[2:]))
"""


def child(kill_at: int, out) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", CHILD, str(kill_at), *RUN, "--out", str(out)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "ref.zarr"
    res = child(0, out)
    assert res.returncode == 0, res.stderr
    total = int(res.stderr.strip().splitlines()[-1])
    return out, total


# A fresh process per kill (about 5 s of CPU each): four writes in the default suite, the
# layout's, a chunk's, the consolidation's and the completion flag's; four more with -m slow.
@pytest.mark.parametrize("spread", ["sample", pytest.param("every", marks=pytest.mark.slow)])
def test_killed_at_any_stage_resumes_identically(reference, tmp_path, capsys, spread):
    ref, total = reference
    assert total > 50
    # the layout's first files, its middle, its last (the done flags), a chunk, the final
    # consolidation and the flag that marks the store complete
    points = {2, total // 3, total - 1, total}
    if spread == "every":
        points |= {10, 40, total // 2, total - 2}
    for n in sorted(points):
        out = tmp_path / f"k{n}.zarr"
        res = child(n, out)
        assert res.returncode == 137, res.stderr
        assert json.loads((out / MARKER).read_text())["format"].startswith("pasim-store")
        state = run_state(out)
        assert state is None or state[0].get("pasim_complete") != "true", n
        code = main([*RUN, "--out", str(out), "--resume"])
        capsys.readouterr()
        assert code == 0, f"resume after a kill at write {n}"
        meta = json.loads((out / "zarr.json").read_text())
        assert "consolidated_metadata" in meta, n
        x = xr.open_datatree(out, engine="zarr")["sweep_0"].to_dataset()
        y = xr.open_datatree(ref, engine="zarr")["sweep_0"].to_dataset()
        for name in y.data_vars:
            np.testing.assert_array_equal(x[name].values, y[name].values, err_msg=f"{n} {name}")
