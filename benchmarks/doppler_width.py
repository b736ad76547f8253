"""Reflectivity estimator noise against pulses, by width model (docs/doppler.md, width section).

    python benchmarks/doppler_width.py [--sector 240:330] [--pulses 64,1024,4096]
                                       [--models physical,truth]

Runs graphs/generic_radar.yaml at the weather channel's ``combined`` level and at its
``expected`` level (no random draw) and prints, per pulse count and ``width_model``, the
std and mean of their DBZH difference over the gates the scorer scores: the estimator noise
alone. About 3 minutes for 240:330 at 4,096 pulses on one core.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pasim_graph.executor import LocalExecutor, RunOptions  # noqa: E402
from pasim_graph.graph import load  # noqa: E402


def dbzh_noise(sector: tuple[float, float], pulses: int, model: str) -> np.ndarray:
    overrides = {
        "scan.azimuth_start_deg": sector[0],
        "scan.azimuth_stop_deg": sector[1],
        "scan.pulses": pulses,
        "weather.width_model": model,
    }
    options = RunOptions(seed=0, fields=("DBZH",), chunk_beams=1)
    graph = ROOT / "graphs" / "generic_radar.yaml"
    drawn = LocalExecutor(load(graph, {**overrides, "weather.method": "combined"}), options).run()
    exact = LocalExecutor(load(graph, {**overrides, "weather.method": "expected"}), options).run()
    scored = np.isfinite(drawn["error_DBZH"].values) & np.isfinite(exact["DBZH"].values)
    return (drawn["DBZH"].values - exact["DBZH"].values)[scored]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sector", default="240:330")
    parser.add_argument("--pulses", default="64,1024,4096")
    parser.add_argument("--models", default="physical,truth")
    args = parser.parse_args()
    a, b = (float(x) for x in args.sector.split(":"))
    print("model     pulses  gates   std (dB)  mean (dB)")
    for model in args.models.split(","):
        for pulses in (int(p) for p in args.pulses.split(",")):
            d = dbzh_noise((a, b), pulses, model)
            print(f"{model:9s} {pulses:6d} {d.size:6d} {np.std(d):9.3f} {np.mean(d):+10.3f}")


if __name__ == "__main__":
    main()
