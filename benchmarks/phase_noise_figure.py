"""The phase-noise-limited clutter suppression against range (docs/phase_noise_coherency.png).

A zero-velocity point target at each range, 64 pulses at a PRT of 1 ms, a receiver of 625 kHz
noise bandwidth (a 1.6 us pulse), through ``receiver.phase_noise`` with two profiles: the
issue's flat -100 dBc/Hz, and an illustrative falling one (not a datasheet's). The block's
residual after removing the dwell mean (200 beams) against the integral of each profile
(tests/reference/phase_noise.py's formula, integrated numerically for the falling profile).

    python benchmarks/phase_noise_figure.py [OUT.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from pasim_blocks.receivers.phase_noise import PhaseNoise, parse_profile, phase_psd

from pasim_graph import Chunk

C = 299_792_458.0
PRT, PULSES, BAND, BEAMS = 1e-3, 64, 625e3, 200
RANGES = np.geomspace(15.0, 140e3, 16)
PROFILES = {
    "flat -100 dBc/Hz": "1e2:-100, 1e8:-100",
    "falling (illustrative): -70 at 100 Hz, -100 at 10 kHz, -125 at 300 kHz": (
        "1e2:-70, 1e3:-85, 1e4:-100, 1e5:-115, 3e5:-125"
    ),
}


def theory_db(profile: str, tau: float) -> float:
    offsets, levels = parse_profile(profile)
    top = BAND / 2
    f = np.linspace(0.5, top, 400_001)
    s = phase_psd(f, offsets, levels)
    w = 4 * s * np.sin(np.pi * f * tau) ** 2
    cov = np.array([np.trapezoid(w * np.cos(2 * np.pi * f * k * PRT), f) for k in range(PULSES)])
    lag = np.abs(np.subtract.outer(np.arange(PULSES), np.arange(PULSES)))
    return float(10 * np.log10(1 - np.exp(-(cov[0] - cov[lag])).sum() / PULSES**2))


def measured_db(profile: str) -> np.ndarray:
    block = PhaseNoise(name="pn", profile_dbc_hz=profile)
    iq = np.ones((BEAMS, RANGES.size, PULSES, 1), np.complex64)
    cal = xr.Dataset({"range": ("range", RANGES)}, attrs={"prt_s": PRT})
    rr = xr.Dataset(attrs={"noise_bandwidth_hz": BAND})
    x = block.process(
        {"iq_in": iq, "calibration": cal, "range_response": rr},
        Chunk(beams=np.arange(BEAMS), seed=1, block_name="pn"),
    )["iq"][..., 0].astype(complex)
    return 10 * np.log10(np.mean(np.abs(x - x.mean(axis=2, keepdims=True)) ** 2, axis=(0, 2)))


def main(out: str) -> None:
    fig, ax = plt.subplots(figsize=(8, 5))
    for i, (name, profile) in enumerate(PROFILES.items()):
        th = [theory_db(profile, 2 * r / C) for r in RANGES]
        me = measured_db(profile)
        ax.semilogx(RANGES / 1e3, th, color=f"C{i}", label=f"{name}: integral of the profile")
        ax.semilogx(RANGES / 1e3, me, "o", color=f"C{i}", label="receiver.phase_noise, 200 beams")
        print(name)
        for r, a, b in zip(RANGES, th, me, strict=True):
            print(f"  {r / 1e3:9.3f} km  theory {a:7.2f} dB  block {b:7.2f} dB")
    ax.set(
        xlabel="range of the zero-velocity target (km)",
        ylabel="power left after removing the dwell mean (dB)",
        title="Phase noise on transmit and receive: near targets stay coherent",
    )
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(
        sys.argv[1]
        if len(sys.argv) > 1
        else str(Path(__file__).parents[1] / "docs" / "phase_noise_coherency.png")
    )
