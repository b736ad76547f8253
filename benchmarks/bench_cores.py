"""What two processes can get out of this machine's cores, without Dask (run by hand, not in CI).

    python benchmarks/bench_cores.py [--graph graphs/generic_radar.yaml] [--sector 0:360]

`bench_scaling.py` measures how `pasim run --workers 2` speeds up the chunk phase against
`--workers 1`. This script measures the ceiling that speed-up is held to by the hardware and
not by the scheduler: the same chunks, computed by `pasim run --scheduler sync` (one thread, no
cluster, no scheduler, nothing shared), first one half of the sector after the other in one
process each, then both halves at the same time in two processes. The chunk phase of each is
read from the run's task record (`pasim_tasks`: its chunk tasks' start and stop), so imports
and set-up are left out as in `bench_scaling.py`.

    ceiling = (chunks of half A alone + chunks of half B alone) / max(chunks of A, B together)

A ceiling below 2 on two cores says the cores slow each other down (shared memory bandwidth,
shared cache, a hypervisor's clock), or that the halves cost unequal times (each half's own
``slowdown``, together over alone, tells the two apart); the same loss holds for two Dask
workers. Without the store and the runs' set-up, ``compute`` rows time the whole sector's
chunks computed by the graph's blocks in one process, alone and then in two processes at once
(each all of them): ``ceiling`` = 2 x alone / the slower of the two, ``cpu_rise`` the
processes' own CPU for the same work, together over alone. A pure-Python
loop (no memory traffic) is measured the same way as a reference for what the cores give
when nothing is shared. Prints JSON lines (and appends them to ``--out``).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pasim_graph.task_record import read_tasks  # noqa: E402


def _spin(n: int) -> float:
    t0 = time.perf_counter()
    x = 0
    for i in range(n):
        x += i * i % 7
    return time.perf_counter() - t0


def python_loop(n: int = 30_000_000) -> dict[str, Any]:
    """The pure-Python loop once alone, then twice at once in two processes."""
    alone = _spin(n)
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        pool.map(_spin, [1000, 1000])  # start both before timing
        t0 = time.perf_counter()
        both = pool.map(_spin, [n, n])
        wall = time.perf_counter() - t0
    return {
        "case": "python_loop",
        "alone_s": alone,
        "together_s": both,
        "wall_s": wall,
        "ceiling": 2 * alone / wall,
    }


def chunk_phase(store: Path) -> float:
    tasks = read_tasks(store)[-1]["tasks"]
    return max(t["stop"] for t in tasks) - min(t["start"] for t in tasks)


def runs(args: argparse.Namespace, sectors: list[str], tmp: Path, tag: str) -> list[float]:
    """Run one `pasim run --scheduler sync` per sector, all at once; their chunk phases."""
    procs = []
    stores = []
    for k, sector in enumerate(sectors):
        out = tmp / f"{tag}-{k}.zarr"
        cmd = [
            sys.executable,
            "-m",
            "pasim_graph",
            "run",
            args.graph,
            "--sector",
            sector,
            "--scheduler",
            "sync",
            "--chunk",
            "8",
            "--out",
            str(out),
        ]
        procs.append(
            subprocess.Popen(
                cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
            )
        )
        stores.append(out)
    for p in procs:
        _, err = p.communicate()
        if p.returncode != 0:
            raise RuntimeError(err[-2000:])
    return [chunk_phase(s) for s in stores]


#: One process's share of ``compute_only``: the sector's chunks computed by the graph's
#: blocks in this process (no Dask, no store), timed from a common start.
_COMPUTE = """
import json, os, sys, time
from pasim_graph import load
from pasim_graph.executor import LocalExecutor, RunOptions, chunks
start, stop = (float(v) for v in sys.argv[2].split(":"))
graph = load(sys.argv[1], {"scan.azimuth_start_deg": start, "scan.azimuth_stop_deg": stop})
ex = LocalExecutor(graph, RunOptions(seed=0, chunk_beams=8))
ex.load()
static = ex.run_static()
every = list(chunks(ex.plan.beam_count, 8))
ex.run_chunk(static, every[0])  # imports and first use, before the clock
print("ready", flush=True)
sys.stdin.readline()
t, c = time.perf_counter(), time.thread_time()
for beams in every:
    ex.run_chunk(static, beams)
print(json.dumps({"wall_s": time.perf_counter() - t, "cpu_s": time.thread_time() - c}))
"""


def compute_only(args: argparse.Namespace, copies: int) -> list[dict[str, float]]:
    """The whole sector's chunks computed in ``copies`` processes at once, each all of them
    (single-threaded BLAS, as a Dask worker runs), started together once all are ready."""
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    cmd = [sys.executable, "-c", _COMPUTE, args.graph, args.sector]
    procs = [
        subprocess.Popen(
            cmd,
            cwd=tempfile.gettempdir(),
            env=env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        for _ in range(copies)
    ]
    for p in procs:
        assert p.stdout is not None and p.stdout.readline().strip() == "ready"
    for p in procs:
        assert p.stdin is not None
        p.stdin.write("go\n")
        p.stdin.flush()
    return [json.loads(p.communicate()[0]) for p in procs]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--graph", default=str(ROOT / "graphs" / "generic_radar.yaml"))
    ap.add_argument("--sector", default="0:360")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "bench_cores.jsonl"))
    args = ap.parse_args()
    start, stop = (float(v) for v in args.sector.split(":"))
    mid = (start + stop) / 2
    halves = [f"{start:g}:{mid:g}", f"{mid:g}:{stop:g}"]
    rows = [python_loop()]
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeat):
            load = os.getloadavg()[0]
            alone = runs(args, halves[:1], Path(tmp), f"a{r}") + runs(
                args, halves[1:], Path(tmp), f"b{r}"
            )
            together = runs(args, halves, Path(tmp), f"t{r}")
            rows.append(
                {
                    "case": "chunks",
                    "sector": args.sector,
                    "halves": halves,
                    "alone_s": alone,
                    "together_s": together,
                    # each half's own slowdown: the halves' costs differ, so the ceiling
                    # is held down by their imbalance as well as by the cores
                    "slowdown": [b / a for a, b in zip(alone, together, strict=True)],
                    "ceiling": sum(alone) / max(together),
                    "load_before": load,
                    "load_after": os.getloadavg()[0],
                }
            )
            one = compute_only(args, 1)[0]
            two = compute_only(args, 2)
            rows.append(
                {
                    "case": "compute",
                    "sector": args.sector,
                    "alone": one,
                    "together": two,
                    "cpu_rise": sum(t["cpu_s"] for t in two) / 2 / one["cpu_s"],
                    "ceiling": 2 * one["wall_s"] / max(t["wall_s"] for t in two),
                    "load_before": load,
                    "load_after": os.getloadavg()[0],
                }
            )
    stamp = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    with open(args.out, "a") as f:
        for row in rows:
            row["date"] = stamp
            line = json.dumps(row)
            print(line)
            f.write(line + "\n")


if __name__ == "__main__":
    main()
