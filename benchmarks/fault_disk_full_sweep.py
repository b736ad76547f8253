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


def run() -> int:
    real = zlocal._put
    calls = [0]

    def counting(*args, **kwargs):
        calls[0] += 1
        return real(*args, **kwargs)

    work = Path(tempfile.mkdtemp())
    zlocal._put = counting
    quiet([*RUN, "--out", str(work / "ref.zarr")])
    zlocal._put = real
    total, ref = calls[0], sweep(work / "ref.zarr")
    bad = []
    for n in range(1, total + 1):
        seen = [0]

        def failing(*args, _n=n, _seen=seen, **kwargs):
            _seen[0] += 1
            if _seen[0] >= _n:
                raise OSError(28, "No space left on device")
            return real(*args, **kwargs)

        out = work / f"n{n}.zarr"
        zlocal._put = failing
        code, err = quiet([*RUN, "--out", str(out)])
        zlocal._put = real
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
