"""Time and peak memory of `pasim run` for the shipped graphs (run by hand, not in CI).

    python benchmarks/bench_run.py [--sector 240:330] [--graphs generic_radar planar_patch_radar]

Prints one JSON line per run: wall seconds, beams, seconds per beam, peak resident memory.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sector", default="240:330")
    ap.add_argument("--graphs", nargs="+", default=["generic_radar", "planar_patch_radar"])
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    a0, a1 = (float(x) for x in args.sector.split(":"))
    beams = round((a1 - a0) % 360 or 360)
    for name in args.graphs:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "run.zarr"
            t0 = time.perf_counter()
            cmd = [
                *(sys.executable, "-m", "pasim_graph", "run"),
                str(ROOT / "graphs" / f"{name}.yaml"),
                *("--sector", args.sector, "--seed", str(args.seed), "--out", str(out)),
            ]
            with tempfile.TemporaryFile() as err:
                child = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err)
                # wait4: this child's own peak (RUSAGE_CHILDREN would keep the largest of all
                # the runs so far).
                _, status, usage = os.wait4(child.pid, 0)
                wall = time.perf_counter() - t0
                if os.waitstatus_to_exitcode(status) != 0:
                    err.seek(0)
                    raise SystemExit(f"{name}: pasim run failed:\n{err.read().decode()}")
        peak_mb = usage.ru_maxrss / 1024
        print(
            json.dumps(
                {
                    "graph": name,
                    "sector": args.sector,
                    "beams": beams,
                    "seconds": round(wall, 1),
                    "seconds_per_beam": round(wall / beams, 3),
                    "peak_memory_mb": round(peak_mb),
                }
            ),
            flush=True,
        )


if __name__ == "__main__":
    main()
