"""The waveform tables and comparison figure of docs/waveforms.md (run by hand).

    python benchmarks/waveform_table.py [--plot docs/waveforms_compare.png]

Prints markdown tables: (1) `pasim waveform` on the three shipped graphs; (2) the NLFM design
steps of docs/waveforms.md at 3.6 MHz x 50 us, 2x oversampled, matched filter; (3) every
waveform through each amplifier and receive filter. All figures come from the blocks and
blocks/compression.py, as `pasim waveform` computes them.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from pasim_blocks.receivers.filters import MatchedFilter, MismatchedFilter
from pasim_blocks.signals import SPEED_OF_LIGHT
from pasim_blocks.transmitters.amplifiers import RappAmplifier, SalehAmplifier
from pasim_blocks.waveforms.chain import analyse
from pasim_blocks.waveforms.compression import power_efficiency, sidelobes
from pasim_blocks.waveforms.nlfm import gaussian_log_density, stationary_phase
from pasim_blocks.waveforms.pulses import LinearFM, NonlinearFM, pulse_dataset

from pasim_graph import Chunk, load

ROOT = Path(__file__).resolve().parents[1]
B_HZ, T_S, FS = 3.6e6, 50e-6, 7.2e6
ONCE = Chunk(beams=np.arange(0))


def made(block):
    return block.process({}, Chunk(beams=np.arange(0), resource=block.load()))["pulse"]


def row(rr) -> tuple[float, float, float, float]:
    lobes = sidelobes(rr["voltage"].values, SPEED_OF_LIGHT / (2 * FS))
    return lobes["psl_db"], lobes["isl_db"], lobes["resolution"], rr.attrs["snr_loss_db"]


def shipped() -> None:
    print(
        "| graph | psl_ideal_db | psl_db | isl_db | power_efficiency | radiated | "
        "range_resolution_m | blind_range_m | snr_loss_db |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name in ("lfm", "taylor_lfm", "nlfm"):
        m = analyse(load(ROOT / "graphs" / f"waveform_{name}.yaml")).metrics
        print(
            f"| waveform_{name} | {m['psl_ideal_db']:.1f} | {m['psl_db']:.1f} | "
            f"{m['isl_db']:.1f} | {m['power_efficiency']:.3f} | "
            f"{m['power_efficiency_radiated']:.3f} | {m['range_resolution_m']:.1f} | "
            f"{m['blind_range_m']:.0f} | {m['snr_loss_db']:.3f} |"
        )


def design_steps() -> None:
    def matched(env):
        p = pulse_dataset(env, FS)
        return MatchedFilter(name="mf").process({"pulse": p, "reference": p}, ONCE)[
            "range_response"
        ]

    steps = [
        (
            "Gaussian density 0.15 B, constant envelope (the paper's recipe)",
            stationary_phase(B_HZ, T_S, FS, gaussian_log_density(0.15)),
        ),
        (
            "Gaussian density 0.18 B, 10 % Tukey taper (energy mapping)",
            stationary_phase(B_HZ, T_S, FS, gaussian_log_density(0.18), 0.1),
        ),
        (
            "Blackman density, 10 % Tukey taper (energy mapping)",
            stationary_phase(
                B_HZ,
                T_S,
                FS,
                lambda x: np.log(
                    0.42 + 0.5 * np.cos(2 * np.pi * x) + 0.08 * np.cos(4 * np.pi * x) + 1e-12
                ),
                0.1,
            ),
        ),
        (
            "optimised (shipped): spline log-density, 9.2 % Tukey taper",
            made(NonlinearFM(name="tx", design="optimised"))["envelope"].values,
        ),
    ]
    print("| NLFM design | psl_db | isl_db | range_resolution_m | power_efficiency |")
    print("|---|---|---|---|---|")
    for label, env in steps:
        psl, isl, res, _ = row(matched(env))
        print(f"| {label} | {psl:.1f} | {isl:.1f} | {res:.1f} | {power_efficiency(env):.3f} |")


def chains(plot: str | None) -> None:
    waveforms = {
        "LFM": LinearFM(name="tx"),
        "Taylor-LFM -60 dB": LinearFM(name="tx", window="taylor"),
        "NLFM optimised": NonlinearFM(name="tx", design="optimised"),
        "NLFM Gaussian": NonlinearFM(name="tx"),
    }
    amplifiers = {
        "ideal": None,
        "Saleh 0 dB": SalehAmplifier(name="hpa"),
        "Saleh 3 dB": SalehAmplifier(name="hpa", input_backoff_db=3.0),
        "Rapp p=2, 0 dB": RappAmplifier(name="hpa"),
    }
    filters = {
        "matched (ideal)": lambda tx, p: MatchedFilter(name="mf").process(
            {"pulse": tx, "reference": p}, ONCE
        ),
        "matched (radiated)": lambda tx, p: MatchedFilter(name="mf").process(
            {"pulse": tx, "reference": tx}, ONCE
        ),
        "Taylor -50 dB, time": lambda tx, p: MismatchedFilter(
            name="mf", taylor_sidelobe_db=-50.0, taylor_nbar=8
        ).process({"pulse": tx, "reference": p}, ONCE),
        "Taylor -70 dB, frequency": lambda tx, p: MismatchedFilter(
            name="mf", domain="frequency", taylor_sidelobe_db=-70.0, taylor_nbar=8
        ).process({"pulse": tx, "reference": p}, ONCE),
    }
    print(
        "| waveform | amplifier | radiated efficiency | filter | psl_db | isl_db | "
        "resolution m | snr_loss_db |"
    )
    print("|---|---|---|---|---|---|---|---|")
    curves = {}
    for wname, block in waveforms.items():
        p = made(block)
        constant = np.ptp(np.abs(p["envelope"].values)) < 1e-9
        for aname, amp in amplifiers.items():
            if constant and amp is not None:
                continue  # a constant envelope only changes by a constant phase and power
            tx = p if amp is None else amp.process({"pulse_in": p}, ONCE)["pulse"]
            eff = power_efficiency(tx["envelope"].values, 1.0)
            for fname, f in filters.items():
                rr = f(tx, p)["range_response"]
                psl, isl, res, loss = row(rr)
                print(
                    f"| {wname} | {aname} | {eff:.3f} | {fname} | {psl:.1f} | {isl:.1f} | "
                    f"{res:.0f} | {loss:.2f} |"
                )
                if fname == "matched (ideal)":
                    curves[(wname, aname)] = rr
    if plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
        for a, aname in zip(ax, ("ideal", "Saleh 0 dB"), strict=True):
            for wname in ("LFM", "Taylor-LFM -60 dB", "NLFM optimised"):
                rr = curves.get((wname, aname), curves[(wname, "ideal")])
                pw = np.abs(rr["voltage"].values) ** 2
                a.plot(
                    rr["offset_m"].values / 1e3,
                    10 * np.log10(pw / pw.max() + 1e-30),
                    label=wname,
                    lw=0.8,
                )
            a.set(
                xlabel="range offset (km)",
                title=f"matched filter, {aname} amplifier",
                ylim=(-100, 3),
                xlim=(-8, 8),
            )
            a.legend(fontsize=8)
        ax[0].set_ylabel("filter output (dB)")
        fig.tight_layout()
        fig.savefig(plot, dpi=100)
        print(f"\nwrote {plot}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plot", help="write the comparison figure here")
    args = ap.parse_args()
    shipped()
    print()
    design_steps()
    print()
    chains(args.plot)


if __name__ == "__main__":
    main()
