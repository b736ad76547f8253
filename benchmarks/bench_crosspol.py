"""Cross-polar coupling in the weather channel: cost, identity and the real volume (by hand).

    python benchmarks/bench_crosspol.py timing --before DIR [--graphs generic_radar \
        planar_patch_radar cppar10_radar] [--levels expected combined covariance] \
        [--sector 240:330] [--repeat 3] [--out FILE.jsonl]
    python benchmarks/bench_crosspol.py volume [--graphs planar_patch_radar cppar10_radar] \
        [--levels covariance expected] [--sector 240:330] [--seed 0] [--out FILE.jsonl]

``timing``: the weather channel's ``process()`` on the same captured inputs (chunks of 8
beams, one BLAS thread, a fresh block per repetition so its once-per-run preparation is
counted), alternating between the code in ``DIR`` (a checkout's ``blocks`` folder, e.g. main
before this change: ``git archive f63a758 blocks | tar -x -C /tmp/before``) and this code,
in SHV and AHV, best of ``--repeat``. It also says whether this code's output is the same to
the bit as the old one's where the antenna gives no cross-polar field (``identical``).

``volume``: the graphs over the sector of the bundled volume, seed 0, without cross-polar
coupling (``weather.cross_polar_coupling=false``: the co-polar power patterns, as before),
with it in SHV and in AHV, and with an element leakage of -25 and -35 dB; bias and std of
every moment against the raw truth on the gates every run of a graph scores.

Prints JSON lines and writes them to ``--out``.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import platform
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MOMENTS = ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH")


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> dict:
    return {
        "kind": "machine",
        "date": time.strftime("%Y-%m-%d"),
        "machine": cpu_model(),
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
        "numpy": np.__version__,
    }


def graph(name: str, sector: str, extra: dict | None = None):
    from pasim_graph import load

    a0, a1 = (float(x) for x in sector.split(":"))
    return load(
        ROOT / "graphs" / f"{name}.yaml",
        {"scan.azimuth_start_deg": a0, "scan.azimuth_stop_deg": a1, **(extra or {})},
    )


def captured_inputs(name: str, sector: str) -> list[tuple[dict, object]]:
    """The weather channel's inputs and chunk for every chunk of 8 beams of a run."""
    from pasim_graph.executor import LocalExecutor, RunOptions, chunks

    ex = LocalExecutor(graph(name, sector), RunOptions(seed=0, chunk_beams=8))
    ex.load()
    static = ex.run_static()
    captured = []
    order = ex.plan.per_chunk
    upstream = order[: order.index("weather")]
    for beams in chunks(ex.plan.beam_count, 8):
        values = dict(static)
        for block in upstream:
            ex._run_block(block, values, beams)
        inputs = {
            e.dst_port: values[(e.src, e.src_port)] for e in ex.plan.graph.inputs_of("weather")
        }
        from pasim_graph import Chunk

        captured.append((inputs, Chunk(beams=beams, seed=0, block_name="weather")))
    return captured


def timing(args: argparse.Namespace, emit) -> None:
    sys.path.insert(0, str(Path(args.before).resolve().parent))
    old_name = Path(args.before).name
    old = importlib.import_module(f"{old_name}.weather").WeatherChannel
    from pasim_blocks.weather.channel import WeatherChannel

    def process(cls, captured, params):
        block = cls(name="weather", **params)
        t = time.perf_counter()
        outs = [block.process(inputs, chunk) for inputs, chunk in captured]
        return time.perf_counter() - t, outs

    for name in args.graphs:
        captured = captured_inputs(name, args.sector)
        coupled = "co_polar" in captured[0][0]["pattern"]
        for level in args.levels:
            variants = {
                "before": (old, {"method": level}),
                "shv": (WeatherChannel, {"method": level}),
                "ahv": (WeatherChannel, {"method": level, "transmission": "ahv"}),
            }
            best = dict.fromkeys(variants, float("inf"))
            outs = {}
            for _ in range(args.repeat):
                for key, (cls, params) in variants.items():
                    seconds, outs[key] = process(cls, captured, params)
                    best[key] = min(best[key], seconds)
            identical = None
            if not coupled:
                identical = all(
                    np.array_equal(a["iq"], b["iq"])
                    and np.array_equal(a["signal_power"], b["signal_power"])
                    and np.array_equal(a["echo_correlations"], b["echo_correlations"][..., :5])
                    and a["calibration"]["radar_constant_db"].equals(
                        b["calibration"]["radar_constant_db"]
                    )
                    for a, b in zip(outs["before"], outs["shv"], strict=True)
                )
            emit(
                {
                    "kind": "timing",
                    "graph": name,
                    "level": level,
                    "sector": args.sector,
                    "cross_polar_fields": coupled,
                    "seconds_best": best,
                    "ratio_shv": best["shv"] / best["before"],
                    "ratio_ahv": best["ahv"] / best["before"],
                    "repeat": args.repeat,
                    "identical": identical,
                }
            )


def volume(args: argparse.Namespace, emit) -> None:
    from pasim_graph.executor import LocalExecutor, RunOptions

    runs = {
        "no coupling": {"weather.cross_polar_coupling": False},
        "SHV": {},
        "AHV": {"weather.transmission": "ahv"},
        "SHV, -35 dB leakage": {"antenna.cross_pol_db": -35.0},
        "AHV, -35 dB leakage": {"antenna.cross_pol_db": -35.0, "weather.transmission": "ahv"},
        "SHV, -25 dB leakage": {"antenna.cross_pol_db": -25.0},
        "AHV, -25 dB leakage": {"antenna.cross_pol_db": -25.0, "weather.transmission": "ahv"},
    }
    for name in args.graphs:
        for level in args.levels:
            results = {}
            for label, extra in runs.items():
                g = graph(name, args.sector, {"weather.method": level, **extra})
                ex = LocalExecutor(g, RunOptions(seed=args.seed, chunk_beams=8))
                t = time.perf_counter()
                sweep = ex.run()
                results[label] = (sweep, time.perf_counter() - t, ex.block_seconds["weather"])
            common = np.logical_and.reduce(
                [np.isfinite(s["error_DBZH"].values) for s, _, _ in results.values()]
            )
            for label, (sweep, seconds, weather_s) in results.items():
                row = {}
                for k in MOMENTS:
                    e = np.where(common, sweep[f"error_{k}"].values, np.nan)
                    e = e[np.isfinite(e)]
                    row[k] = {
                        "bias": float(e.mean()),
                        "std": float(e.std(ddof=1)),
                        "count": int(e.size),
                    }
                emit(
                    {
                        "kind": "volume",
                        "graph": name,
                        "level": level,
                        "run": label,
                        "sector": args.sector,
                        "seed": args.seed,
                        "seconds_run": seconds,
                        "seconds_weather": weather_s,
                        "moments": row,
                    }
                )


def main() -> None:
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="what", required=True)
    t = sub.add_parser("timing")
    t.add_argument("--before", required=True, help="a 'blocks' folder of the code before")
    t.add_argument(
        "--graphs", nargs="+", default=["generic_radar", "planar_patch_radar", "cppar10_radar"]
    )
    t.add_argument("--levels", nargs="+", default=["expected", "combined", "covariance"])
    t.add_argument("--sector", default="240:330")
    t.add_argument("--repeat", type=int, default=3)
    t.add_argument("--out", default=None)
    v = sub.add_parser("volume")
    v.add_argument("--graphs", nargs="+", default=["planar_patch_radar", "cppar10_radar"])
    v.add_argument("--levels", nargs="+", default=["covariance", "expected"])
    v.add_argument("--sector", default="240:330")
    v.add_argument("--seed", type=int, default=0)
    v.add_argument("--out", default=None)
    args = ap.parse_args()
    out = open(args.out, "a") if args.out else None

    def emit(row: dict) -> None:
        line = json.dumps(row)
        print(line, flush=True)
        if out:
            out.write(line + "\n")
            out.flush()

    emit(machine())
    timing(args, emit) if args.what == "timing" else volume(args, emit)


if __name__ == "__main__":
    main()
