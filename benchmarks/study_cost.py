"""The per-beam and per-run costs behind ``pasim study``'s time estimate (run by hand).

    python benchmarks/study_cost.py [--methods expected combined covariance] [--beams 4 24]

Runs the generic radar (64 pulses, H and V, the bundled scene at 0.5 deg) as a study runs a
run (one process, ``DaskExecutor`` with its default scheduler, the store written), at each
weather ``method`` (fidelity level) on two sector widths after a warm-up run, and fits
``seconds = per_run + beams x per_beam``, in wall seconds and in CPU seconds of the process
(every thread: what the run costs whatever else shares the machine). Prints one JSON line
per method with the load average; the CPU numbers go to
``PER_BEAM_S`` and ``PER_RUN_S`` in ``blocks/study/sizing.py``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def timed(method: str, beams: int, out: Path) -> tuple[float, float]:
    """Wall and CPU seconds (every thread of this process) of one run."""
    from pasim_graph.dask_executor import DaskExecutor
    from pasim_graph.executor import RunOptions
    from pasim_graph.graph import resolve

    overrides = {
        "weather.method": method,
        "scan.azimuth_start_deg": 280.0,
        "scan.azimuth_stop_deg": 280.0 + beams,
    }
    graph = resolve(str(ROOT / "graphs" / "generic_radar.yaml"), overrides=overrides).graph
    t0, c0 = time.perf_counter(), time.process_time()
    DaskExecutor(graph, RunOptions(seed=0)).run(out, {"title": "study cost"})
    return time.perf_counter() - t0, time.process_time() - c0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--methods", nargs="+", default=["expected", "combined", "covariance"])
    ap.add_argument("--beams", nargs=2, type=int, default=[4, 24])
    args = ap.parse_args()
    small, large = args.beams
    with tempfile.TemporaryDirectory() as tmp:
        timed("expected", 2, Path(tmp) / "warm.zarr")  # imports, caches
        for method in args.methods:
            t = {n: timed(method, n, Path(tmp) / f"{method}-{n}.zarr") for n in (small, large)}
            line: dict[str, object] = {"method": method, "load": os.getloadavg()[0]}
            for i, what in enumerate(("wall", "cpu")):
                per_beam = (t[large][i] - t[small][i]) / (large - small)
                line[what] = {
                    "seconds": {str(k): round(v[i], 3) for k, v in t.items()},
                    "per_beam_s": round(per_beam, 4),
                    "per_run_s": round(t[small][i] - small * per_beam, 3),
                }
            print(json.dumps(line), flush=True)


if __name__ == "__main__":
    main()
