"""The numerical extremes of docs/extremes.md, measured (run by hand, not in CI).

    python benchmarks/extremes_cases.py [--out FILE.jsonl]

Runs each case through `pasim run` on graphs/uniform_ideal.yaml (40 beams x 100 gates; the
1024-pulse case on 10 beams) or graphs/core_contamination.yaml, seed 0, and prints one JSON
line per case: the settings, the wall time and peak resident memory of the run, and
`pasim score --json` (bias, std, count, unestimated and scored gates per moment).
`tests/end_to_end/test_extremes.py` checks the same cases against theory on 10 beams.
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
UNIFORM = ROOT / "graphs" / "uniform_ideal.yaml"
CORE = ROOT / "graphs" / "core_contamination.yaml"
CASES = [
    ("width 0 m/s", UNIFORM, ["scene.spectrum_width_ms=0.0"]),
    ("width 0.01 m/s", UNIFORM, ["scene.spectrum_width_ms=0.01"]),
    ("rho_hv = 1", UNIFORM, ["scene.cross_correlation_ratio=1.0"]),
    ("truth rho_hv = 1.05", UNIFORM, ["scene.cross_correlation_ratio=1.05"]),
    ("-30 dBZ next to 80 dBZ", CORE, ["scene.reflectivity_dbz=-30", "scene.core_dbz=80"]),
    (
        "-30 dBZ next to 80 dBZ, no censoring",
        CORE,
        ["scene.reflectivity_dbz=-30", "scene.core_dbz=80"]
        + [f"ppp.snr_threshold_{k}_db=null" for k in ("reflectivity", "doppler", "polarimetric")],
    ),
    ("SNR -20 dB", UNIFORM, ["receiver.snr_db=-20"]),
    ("2 pulses", UNIFORM, ["scan.pulses=2"]),
    ("1024 pulses", UNIFORM, ["scan.pulses=1024", "scan.azimuth_stop_deg=10"]),
    ("velocity 40 m/s", UNIFORM, ["scene.velocity_ms=40"]),
    ("phi_DP 359.5 deg", UNIFORM, ["scene.differential_phase_deg=359.5"]),
    ("phi_DP -10 deg", UNIFORM, ["scene.differential_phase_deg=-10"]),
    ("phi_DP 370 deg", UNIFORM, ["scene.differential_phase_deg=370"]),
    ("all-masked sector", UNIFORM, ["scene.masked=true"]),
]


def pasim(*args: str) -> list[str]:
    return [sys.executable, "-m", "pasim_graph", *args]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=None, help="also write the lines to this file")
    args = ap.parse_args()
    lines = []
    for name, graph, sets in CASES:
        with tempfile.TemporaryDirectory() as tmp:
            store = Path(tmp) / "run.zarr"
            cmd = pasim("run", str(graph), "--seed", "0", "--out", str(store))
            for s in sets:
                cmd += ["--set", s]
            t0 = time.perf_counter()
            log = Path(tmp) / "stderr.txt"
            with log.open("w") as err:
                proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err)
                # wait4: this run's own peak memory (RUSAGE_CHILDREN keeps the largest so far).
                _, status, usage = os.wait4(proc.pid, 0)
            seconds = time.perf_counter() - t0
            stderr = log.read_text()
            if os.waitstatus_to_exitcode(status) != 0:
                raise RuntimeError(f"{name}: {stderr}")
            score = json.loads(
                subprocess.run(
                    pasim("score", str(store), "--json"), capture_output=True, text=True, check=True
                ).stdout
            )
        row = {
            "case": name,
            "graph": graph.name,
            "set": sets,
            "seconds": round(seconds, 2),
            "peak_memory_mb": round(usage.ru_maxrss / 1024),
            "stderr": stderr.strip().splitlines(),
            "score": score,
        }
        lines.append(json.dumps(row))
        print(lines[-1], flush=True)
    if args.out:
        Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
