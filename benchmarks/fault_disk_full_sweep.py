"""Disk full at every single file write of a small run: each must end in exit 2, and the store
must then complete (--resume) or be rerun to the same numbers.

The unit test (tests/store/test_disk_full.py) samples a dozen write positions; this sweeps all of
them (about 280 runs, 3-4 minutes on 2 cores). Run: python benchmarks/fault_disk_full_sweep.py
"""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr
import zarr.storage._local as zlocal

import pasim_graph.store.writes as writes
from pasim_graph.cli import main
from pasim_graph.store import is_store, run_state

ROOT = Path(__file__).resolve().parents[1]
RUN = ["run", str(ROOT / "graphs" / "uniform_ideal.yaml"), "--set", "scan.azimuth_stop_deg=8"]
RUN += ["--set", "scan.pulses=16", "--chunk", "2", "--seed", "4"]


def quiet(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    return code, err.getvalue()


def sweep(path: Path) -> xr.Dataset:
    return xr.open_datatree(path, engine="zarr")["sweep_0"].to_dataset()


#: Every file write of a store: zarr's (layout, metadata) and the chunk files'.
REAL = {zlocal: ("_put", zlocal._put), writes: ("put_file", writes.put_file)}


def patched(seen: list[int], fail_at: int | None) -> None:
    """Each file write counted in ``seen``, failing with ENOSPC from the ``fail_at``-th."""
    for module, (name, real) in REAL.items():

        def write(*args, _real=real, **kwargs):
            seen[0] += 1
            if fail_at is not None and seen[0] >= fail_at:
                raise OSError(28, "No space left on device")
            return _real(*args, **kwargs)

        setattr(module, name, write)


def restored() -> None:
    for module, (name, real) in REAL.items():
        setattr(module, name, real)


def run() -> int:
    calls = [0]
    work = Path(tempfile.mkdtemp())
    patched(calls, None)
    quiet([*RUN, "--out", str(work / "ref.zarr")])
    restored()
    total, ref = calls[0], sweep(work / "ref.zarr")
    bad = []
    for n in range(1, total + 1):
        out = work / f"n{n}.zarr"
        patched([0], n)
        code, err = quiet([*RUN, "--out", str(out)])
        restored()
        resumable = out.exists() and is_store(out) and run_state(out) is not None
        code2, err2 = quiet([*RUN, "--out", str(out), *(["--resume"] if resumable else [])])
        got = sweep(out) if code2 == 0 else None
        same = got is not None and all(
            np.array_equal(ref[v].values, got[v].values, equal_nan=ref[v].dtype.kind in "fc")
            for v in ref.data_vars
        )
        if code != 2 or "the disk is full" not in err or not same:
            bad.append((n, code, err.strip()[-160:], code2, err2.strip()[-160:]))
        shutil.rmtree(out, ignore_errors=True)
    shutil.rmtree(work, ignore_errors=True)
    print(f"{total} write positions, {len(bad)} not ending cleanly")
    for item in bad:
        print(" ", item)
    return 1 if bad else 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONWARNINGS", "ignore")
    sys.exit(run())
