"""Design the optimised NLFM and write it to blocks/data/nlfm_optimised.json (run by hand).

    python benchmarks/design_nlfm.py [--check]

Runs blocks/nlfm.py's ``design_optimised`` (differential evolution from three seeds, then
Nelder-Mead; a few minutes on two cores) for the paper's section 2.3 pulse (3.6 MHz x 50 us,
time-bandwidth product 180) at 2x oversampling, with the mainlobe excluded to 5 / B (where the
-60 dB Taylor-windowed LFM has its first null) and a Tukey taper of at most 0.2 (power
efficiency at least 0.875, the paper's 0.87). Prints the design with the figures `pasim
waveform` reports for it. ``--check`` compares a fresh design with the shipped file instead of
writing it.
"""

from __future__ import annotations

import argparse
import datetime
import json
import platform
import time

import numpy as np
import scipy
from pasim_blocks.signals import SPEED_OF_LIGHT
from pasim_blocks.waveforms.nlfm import OPTIMISED_FILE, design_optimised, optimised_envelope
from pasim_blocks.waveforms.pulse_compression import power_efficiency, sidelobes

BANDWIDTH_HZ, WIDTH_S, OVERSAMPLING = 3.6e6, 50e-6, 2.0


def figures(design: dict) -> dict:
    """PSL, ISL and -6 dB resolution through the matched filter, as `pasim waveform` has them."""
    fs = OVERSAMPLING * BANDWIDTH_HZ
    env = optimised_envelope(design, BANDWIDTH_HZ, WIDTH_S, fs)
    y = np.convolve(env, np.conj(env[::-1])) / np.sum(np.abs(env) ** 2)
    lobes = sidelobes(y, SPEED_OF_LIGHT / (2 * fs))
    return {
        "psl_db": round(lobes["psl_db"], 2),
        "isl_db": round(lobes["isl_db"], 2),
        "range_resolution_m": round(lobes["resolution"], 1),
        "power_efficiency": round(power_efficiency(env), 4),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="compare with the shipped design")
    args = ap.parse_args()
    t0 = time.perf_counter()
    design = design_optimised(
        time_bandwidth=BANDWIDTH_HZ * WIDTH_S,
        oversampling=OVERSAMPLING,
        knots=6,
        max_taper_fraction=0.2,
        exclusion_over_bandwidth=5.0,
    )
    seconds = time.perf_counter() - t0
    design["design_seconds"] = round(seconds, 1)
    design["produced_by"] = "benchmarks/design_nlfm.py"
    design["date"] = datetime.date.today().isoformat()
    design["machine"] = (
        f"{platform.machine()}, {platform.python_version()}, scipy {scipy.__version__}"
    )
    design["figures_at_3.6MHz_50us"] = figures(design)
    print(json.dumps(design, indent=1))
    if args.check:
        shipped = json.loads(OPTIMISED_FILE.read_text())
        diff = design["peak_sidelobe_db"] - shipped["peak_sidelobe_db"]
        print(
            f"fresh design {design['peak_sidelobe_db']:.2f} dB, shipped "
            f"{shipped['peak_sidelobe_db']:.2f} dB (difference {diff:+.2f} dB)"
        )
        return
    OPTIMISED_FILE.write_text(json.dumps(design, indent=1) + "\n")
    print(f"wrote {OPTIMISED_FILE} ({seconds:.0f} s)")


if __name__ == "__main__":
    main()
