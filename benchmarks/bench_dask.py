"""Throughput and peak memory of the Dask executor (issue 6; run by hand, not in CI).

    python benchmarks/bench_dask.py [--quick]

Runs `pasim run graphs/generic_radar.yaml` on the bundled scene over sectors of 30, 90 and 360
deg with chunks of 8 beams (threads), chunks of 2, 8 and 32 beams on 90 deg, and 1 vs 2
dask.distributed workers on 90 deg. Peak memory is the largest summed resident memory of the
run's whole process tree (workers included), sampled every 50 ms with psutil. Also measures
this machine's normal-deviate rate, to express each run against the floor of design-notes
section 6. Prints one JSON line per run and a Markdown table.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import psutil

ROOT = Path(__file__).resolve().parents[1]
GRAPH = ROOT / "graphs" / "generic_radar.yaml"
SECTOR_START = 240.0


def tree_rss(proc: psutil.Process) -> int:
    total = 0
    for p in [proc, *proc.children(recursive=True)]:
        try:
            total += p.memory_info().rss
        except psutil.Error:
            pass
    return total


def run(sector_deg: float, chunk: int, workers: int | None) -> dict:
    a1 = (SECTOR_START + sector_deg) % 360.0
    sector = f"{SECTOR_START:g}:{a1:g}" if sector_deg < 360 else "0:360"
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [
            sys.executable,
            "-m",
            "pasim_graph",
            "run",
            str(GRAPH),
            "--sector",
            sector,
            "--chunk",
            str(chunk),
            "--out",
            str(Path(tmp) / "run.zarr"),
        ]
        if workers:
            cmd += ["--workers", str(workers)]
        t0 = time.perf_counter()
        log = Path(tmp) / "stderr.txt"
        with log.open("w") as err:
            proc = psutil.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err)
            peak = 0
            while proc.poll() is None:
                peak = max(peak, tree_rss(proc))
                time.sleep(0.05)
        wall = time.perf_counter() - t0
        text = log.read_text()
        if proc.returncode:
            raise RuntimeError(text)
        found = re.search(r"chunks in ([0-9.]+) s", text)
        chunk_seconds = float(found.group(1)) if found else float("nan")
    beams = round(sector_deg)
    return {
        "sector_deg": sector_deg,
        "chunk": chunk,
        "workers": workers or "threads",
        "beams": beams,
        "seconds": round(wall, 1),
        "chunk_seconds": chunk_seconds,
        "beams_per_s": round(beams / wall, 2),
        "peak_memory_mb": round(peak / 2**20),
    }


def deviate_rate() -> float:
    rng = np.random.default_rng(0)
    rng.standard_normal(10_000_000, dtype=np.float32)
    t0 = time.perf_counter()
    rng.standard_normal(50_000_000, dtype=np.float32)
    return 50e6 / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="skip the 360 deg run")
    args = ap.parse_args()
    rate = deviate_rate()
    print(json.dumps({"normal_deviates_per_s_one_thread": round(rate / 1e6, 1)}), flush=True)
    configs = [
        (30, 8, None),
        (90, 8, None),
        *([] if args.quick else [(360, 8, None)]),
        (90, 2, None),
        (90, 32, None),
        (90, 8, 1),
        (90, 8, 2),
    ]
    rows = []
    for sector, chunk, workers in configs:
        row = run(sector, chunk, workers)
        rows.append(row)
        print(json.dumps(row), flush=True)
    print("\n| sector | chunk | scheduler | s (whole run) | s (chunks) | beams/s | peak MB |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        sched = "threads" if r["workers"] == "threads" else f"{r['workers']} workers"
        print(
            f"| {r['sector_deg']} | {r['chunk']} | {sched} | {r['seconds']} | "
            f"{r['chunk_seconds']} | {r['beams_per_s']} | {r['peak_memory_mb']} |"
        )


if __name__ == "__main__":
    main()
