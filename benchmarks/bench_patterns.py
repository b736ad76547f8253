"""Time of the antenna blocks per beam, ideal and with channel electronics.

    python benchmarks/bench_patterns.py [--repeat 3] [--json benchmarks/results/bench_patterns.json]

Each case runs one chunk of 8 beams across the sector 240-330 deg (0.5 deg elevation, the
default +-10 deg grid at 0.05 deg) through a freshly built block (its set-up excluded),
back to back in one process; the best of ``--repeat`` is kept, since other work on the
machine only ever slows a run down.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from datetime import date
from pathlib import Path

import numpy as np
import xarray as xr

IMPAIRED = {
    "amplitude_error_db": 0.5,
    "phase_error_deg": 6.0,
    "failure_probability": 0.05,
    "phase_bits": 5,
}


def cases():
    from pasim_blocks.antennas.cylindrical import CylindricalArray
    from pasim_blocks.antennas.pencil import PencilBeamAntenna
    from pasim_blocks.antennas.planar import PlanarPatchArray

    return [
        ("pencil (generic)", PencilBeamAntenna, {}),
        ("planar 80x80, ideal", PlanarPatchArray, {}),
        ("planar 80x80, 5-bit", PlanarPatchArray, {"phase_bits": 5}),
        ("planar 80x80, impaired", PlanarPatchArray, IMPAIRED),
        ("cylinder 10 m, ideal", CylindricalArray, {}),
        ("cylinder 10 m, impaired", CylindricalArray, IMPAIRED),
    ]


def main() -> None:
    from pasim_graph import Chunk

    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    az = 240.5 + np.arange(8) * 11.25
    beams = xr.Dataset(
        coords={"azimuth": ("beam", az), "elevation": ("beam", np.full(az.size, 0.5))}
    )
    rows = []
    for label, cls, params in cases():
        best = np.inf
        for _ in range(args.repeat):
            block = cls(name="antenna", **params)
            t0 = time.perf_counter()
            block.process({"beams": beams}, Chunk(beams=np.arange(az.size), block_name="antenna"))
            best = min(best, time.perf_counter() - t0)
        rows.append({"case": label, "seconds_per_beam": best / az.size})
        print(f"{label:28s} {best / az.size * 1e3:8.1f} ms per beam")
    if args.json:
        Path(args.json).write_text(
            json.dumps(
                {
                    "date": date.today().isoformat(),
                    "machine": f"{platform.processor() or platform.machine()}, "
                    f"{platform.python_version()}",
                    "rows": rows,
                },
                indent=1,
            )
        )


if __name__ == "__main__":
    main()
