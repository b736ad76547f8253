"""What one day of the WSR-88D network costs to simulate (run by hand, not in CI).

    python benchmarks/bench_network_day.py [--methods combined covariance] [--beams 3]
        [--sites 159] [--volume-s 270] [--cores 1000] [--out FILE]

Runs ``graphs/generic_vcp212.yaml`` (VCP 212: 17 rotations from 0.5 to 19.5 deg, the split
cuts' surveillance and Doppler rotations each counted) on ``--beams`` beams of every rotation,
once to warm the process up and once measured, at each weather ``method`` (fidelity), with
dask's synchronous scheduler: every chunk in this thread, one task per rotation. From the
store's task record (``pasim_tasks``) it takes each rotation's task CPU seconds (the task's
thread: what it costs whatever else shares the machine), gates, pulses and bytes, and fits

    CPU s per beam = per_beam_s + per_gate_pulse_s x gates x pulses

over the rotations. The run's set-up (reading the inputs, the once-per-run blocks, the layout:
the steps of the record) is its CPU per volume. With these, the makespan model of
``bench_scaling.py`` (chunks handed to whichever worker is free first; a volume's set-up is a
task of its own; the scheduler's cost per task) gives a day of the whole network:

- core-hours: volumes x (set-up + sum over rotations of 360 beams x CPU per beam);
- wall time on ``--cores`` workers: core-hours / cores (a day is millions of chunk tasks of a
  fraction of a second: the free-first makespan is the average load plus one task), or the
  scheduler's time for every task, whichever is longer (one dask scheduler hands out some
  thousands of tasks a second: ``--scheduler-task-s``);
- bytes written: each rotation's stored bytes per beam (on disk, compressed, from the
  store's files of the arrays along the beams; and uncompressed, from the record) x 360
  beams x volumes.

Prints one JSON line per method (appended to ``--out``) with the machine, the date and the
load average.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

GRAPH = ROOT / "graphs" / "generic_vcp212.yaml"


def run_once(method: str, beams: int, out: Path) -> tuple[dict[str, Any], float]:
    """One run of ``beams`` beams per rotation at ``method``; its task record and the CPU
    seconds of the whole run in this process."""
    from pasim_graph.dask_executor import DaskExecutor
    from pasim_graph.executor import RunOptions
    from pasim_graph.graph import resolve
    from pasim_graph.task_record import read_tasks

    overrides = {
        "weather.method": method,
        "scan.azimuth_start_deg": 240.0,
        "scan.azimuth_stop_deg": 240.0 + beams,
    }
    graph = resolve(str(GRAPH), overrides=overrides).graph
    cpu = time.process_time()
    DaskExecutor(graph, RunOptions(seed=0, chunk_beams=beams), scheduler="sync").run(
        out, {"title": "network day"}
    )
    return read_tasks(out)[-1], time.process_time() - cpu


def rotation_sizes(store: Path) -> dict[str, dict[str, Any]]:
    """Each rotation's (sweep group's) gates and pulses, and its files' bytes on disk."""
    import xarray as xr

    from pasim_graph.store import beam_dimension

    tree = xr.open_datatree(store, engine="zarr")
    sizes = {}
    for name in sorted(tree.children):
        if not name.startswith("sweep_"):
            continue
        ds = tree[name].to_dataset()
        # The arrays along the beams only: the rest (range coordinates, metadata) is written
        # once per rotation, not per beam.
        beam_dim = beam_dimension(ds)
        along = [str(v) for v in ds.variables if beam_dim in ds[v].dims]
        disk = sum(
            f.stat().st_size for v in along for f in (store / name / v).rglob("*") if f.is_file()
        )
        sizes[name] = {
            "gates": int(ds.sizes["range"]),
            "elevation_deg": float(np.asarray(ds["sweep_fixed_angle"])),
            "disk_bytes": disk,
        }
    return sizes


def pulses_by_rotation() -> list[int]:
    from pasim_blocks.scans.vcp import PRESETS

    return [cut.pulses for cut in PRESETS["vcp212"]]


def measure(method: str, beams: int) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="pasim-netday-") as tmp:
        run_once(method, beams, Path(tmp) / "warm.zarr")
        record, run_cpu = run_once(method, beams, Path(tmp) / "run.zarr")
        sizes = rotation_sizes(Path(tmp) / "run.zarr")
    pulses = pulses_by_rotation()
    rows = []
    for task in sorted(record["tasks"], key=lambda t: t["index"]):
        lo, hi = task["beams"]
        size = sizes[task["group"]]
        k = int(task["group"].split("_")[1])
        rows.append(
            {
                "group": task["group"],
                "elevation_deg": size["elevation_deg"],
                "gates": size["gates"],
                "pulses": pulses[k],
                "cpu_per_beam_s": task["cpu_s"] / (hi - lo),
                "bytes_per_beam": task["bytes"] / (hi - lo),
                "disk_bytes_per_beam": size["disk_bytes"] / (hi - lo),
            }
        )
    gp = np.array([r["gates"] * r["pulses"] for r in rows], float)
    cost = np.array([r["cpu_per_beam_s"] for r in rows])
    (per_gate_pulse, per_beam), *_ = np.linalg.lstsq(
        np.column_stack([gp, np.ones_like(gp)]), cost, rcond=None
    )
    fitted = per_beam + per_gate_pulse * gp
    setup = {s["kind"]: s["cpu_s"] for s in record["steps"]}
    return {
        "method": method,
        "beams_per_rotation": beams,
        "rotations": rows,
        "per_beam_s": float(per_beam),
        "per_gate_pulse_s": float(per_gate_pulse),
        "fit_worst_rel": float(np.max(np.abs(fitted - cost) / cost)),
        "setup_cpu_s": setup,
        "run_cpu_s": run_cpu,
    }


def network_day(m: dict[str, Any], args: argparse.Namespace) -> dict[str, Any]:
    """The arithmetic of the module's docstring, for one method."""
    volumes = args.sites * 86400.0 / args.volume_s
    radials = 360  # 1 deg beams, as the graph scans (super-resolution cuts would double some)
    beam_cpu = sum(r["cpu_per_beam_s"] for r in m["rotations"]) * radials
    model_cpu = sum(m["per_beam_s"] + m["per_gate_pulse_s"] * r["gates"] * r["pulses"]
                    for r in m["rotations"]) * radials  # fmt: skip
    setup = sum(m["setup_cpu_s"].get(k, 0.0) for k in ("load", "static", "layout"))
    volume_cpu = beam_cpu + setup
    core_hours = volumes * volume_cpu / 3600.0
    tasks = volumes * (len(m["rotations"]) * radials / args.chunk + 1)
    task_s = beam_cpu / (len(m["rotations"]) * radials / args.chunk)
    wall_cores = volumes * volume_cpu / args.cores + max(task_s, setup)
    wall_scheduler = tasks * args.scheduler_task_s
    disk = sum(r["disk_bytes_per_beam"] for r in m["rotations"]) * radials * volumes
    raw = sum(r["bytes_per_beam"] for r in m["rotations"]) * radials * volumes
    return {
        "volumes": volumes,
        "volume_cpu_s": volume_cpu,
        "volume_cpu_model_s": model_cpu + setup,
        "core_hours": core_hours,
        "tasks": tasks,
        "wall_h_on_cores": wall_cores / 3600.0,
        "wall_h_scheduler": wall_scheduler / 3600.0,
        "wall_h": max(wall_cores, wall_scheduler) / 3600.0,
        "disk_tb": disk / 1e12,
        "uncompressed_tb": raw / 1e12,
    }


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--methods", nargs="+", default=["combined", "covariance"])
    p.add_argument("--beams", type=int, default=3, help="beams measured per rotation")
    p.add_argument("--sites", type=int, default=159)
    p.add_argument("--volume-s", type=float, default=270.0, help="VCP 212's volume time")
    p.add_argument("--cores", type=int, default=1000)
    p.add_argument("--chunk", type=int, default=8, help="beams per chunk task on the cluster")
    p.add_argument("--scheduler-task-s", type=float, default=1e-3,
                   help="one dask scheduler's time per task")  # fmt: skip
    p.add_argument("--out", type=Path)
    args = p.parse_args()
    cpu = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
    model = next((ln.split(":", 1)[1].strip() for ln in cpu.splitlines()
                  if ln.startswith("Model name")), platform.processor())  # fmt: skip
    for method in args.methods:
        m = measure(method, args.beams)
        line = {
            "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "machine": f"{model}, {os.cpu_count()} cores",
            "load": os.getloadavg()[0],
            **m,
            "network_day": network_day(m, args),
            "assumptions": {k: v for k, v in vars(args).items() if k not in ("out", "methods")},
        }
        text = json.dumps(line)
        print(text, flush=True)
        if args.out:
            with open(args.out, "a") as f:
                f.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
