"""The monte_carlo level's cost with drop size distributions against equal drops.

The weather channel alone (``channel.weather`` ``method: monte_carlo``, 256 drops per cell) on a
uniform truth of 40 dBZ and ZDR 1.5 dB: 10 beams, 120 gates, 64 pulses, two chunks (seeds) per
block instance, three repetitions, CPU seconds per call, one thread. Prints the moments of the
gamma drops' series beside (ZDR, pooled rho_hv per gate, PHIDP slope).

    OMP_NUM_THREADS=1 PYTHONPATH=. python benchmarks/bench_dsd.py
"""

from __future__ import annotations

import time

import numpy as np
from pasim_blocks.weather.channel import WeatherChannel

from pasim_graph import Chunk
from tests.weather.test_block_weather import chain_inputs, uniform_truth


def main() -> None:
    beams = np.arange(10)
    truth = uniform_truth(n_gates=120, DBZH=40.0, ZDR=1.5, RHOHV=0.98, PHIDP=0.0)
    inputs = chain_inputs(truth, beams)
    times: dict[str, list[float]] = {"equal": [], "gamma": []}
    out = None
    for _ in range(3):
        for kind in times:
            block = WeatherChannel(name="weather", method="monte_carlo", drop_sizes=kind)
            for seed in (3, 4):
                t = time.process_time()
                out = block.process(inputs, Chunk(beams=beams, seed=seed, block_name="weather"))
                times[kind].append(time.process_time() - t)
    for kind, spent in times.items():
        print(f"{kind}: CPU s per call {np.min(spent):.2f} min, {np.median(spent):.2f} median")
    assert out is not None
    iq = out["iq"][:, 5:-5].astype(np.complex128)
    h, v = iq[..., 0], iq[..., 1]
    p_h = (np.abs(h) ** 2).mean(axis=(0, 2))
    p_v = (np.abs(v) ** 2).mean(axis=(0, 2))
    x = (np.conj(h) * v).mean(axis=(0, 2))
    slope = np.polyfit(truth["range"].values[5:-5] / 1e3, np.unwrap(np.angle(x)), 1)[0]
    print(
        f"gamma drops: ZDR {10 * np.log10(p_h.mean() / p_v.mean()):.3f} dB, rho_hv "
        f"{np.mean(np.abs(x) / np.sqrt(p_h * p_v)):.5f}, PHIDP slope {np.rad2deg(slope):.3f} deg/km"
    )


if __name__ == "__main__":
    main()
