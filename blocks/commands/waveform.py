"""``pasim waveform GRAPH``: a graph's pulse through its amplifier and receive filter.

The chain and its figures of merit are :mod:`pasim_blocks.waveforms.chain`; this module parses,
calls, plots and prints.
"""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import numpy as np

from pasim_graph.command_api import add_graph_arguments, load_graph
from pasim_graph.outputs import write_atomic

from ..waveforms.chain import Analysis, ChainError, analyse
from .reporting import report


def plot(analysis: Analysis, path: str) -> None:
    """Envelope and AM/PM before and after the amplifier, spectra, and both filter outputs
    (the paper's figure 4), with the figures of merit."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = analysis.metrics
    fs = m["sample_rate_hz"]
    before = analysis.drive["envelope"].values
    after = analysis.actual["transmitted"].values
    t_us = np.arange(before.size) / fs * 1e6
    amps = " + ".join(m["amplifiers"]) or "no amplifier"
    fig, ax = plt.subplots(2, 3, figsize=(15, 8))

    a = ax[0, 0]
    a.plot(t_us, np.abs(before), label="drive (ideal transmitter)")
    a.plot(t_us, np.abs(after), "--", label=f"radiated ({amps})")
    a.set(xlabel="time (us)", ylabel="amplitude (1 = rated peak)", title="(a) envelope")
    a.legend(loc="lower center", fontsize=8)

    a = ax[0, 1]
    a.plot(t_us, np.degrees(np.angle(after * np.conj(before))), color="C3")
    a.set(xlabel="time (us)", ylabel="phase added (deg)", title="(b) amplifier AM/PM")

    a = ax[0, 2]
    n_fft = 1 << int(np.ceil(np.log2(8 * before.size)))
    f_mhz = np.fft.fftshift(np.fft.fftfreq(n_fft, 1 / fs)) / 1e6
    for env, style, label in ((before, "-", "drive"), (after, "--", "radiated")):
        spec = np.abs(np.fft.fftshift(np.fft.fft(env, n_fft))) ** 2
        a.plot(f_mhz, 10 * np.log10(spec / spec.max() + 1e-30), style, label=label)
    a.set(xlabel="frequency (MHz)", ylabel="power (dB)", title="(c) spectrum", ylim=(-100, 3))
    a.legend(fontsize=8)

    zoom = 15 * max(m["range_resolution_ideal_m"], m["range_resolution_m"]) / 1e3
    for a, span, title in ((ax[1, 0], None, "(d) filter output"), (ax[1, 1], zoom, "(e) zoom")):
        for rr, style, label, key in (
            (analysis.ideal, "-", "ideal amplifier", "psl_ideal_db"),
            (analysis.actual, "--", f"through {amps}", "psl_db"),
        ):
            x_km = rr["offset_m"].values / 1e3
            p = np.abs(rr["voltage"].values) ** 2
            a.plot(
                x_km,
                10 * np.log10(p / p.max() + 1e-30),
                style,
                label=f"{label}: PSL {m[key]:.1f} dB",
            )
        a.set(xlabel="range offset (km)", ylabel=f"{m['filter']} output (dB)", title=title)
        a.set_ylim(-110, 3)
        if span is not None:
            a.set_xlim(-span, span)
        a.legend(fontsize=8, loc="upper right")

    a = ax[1, 2]
    a.axis("off")
    keys = (
        "psl_db",
        "psl_ideal_db",
        "isl_db",
        "power_efficiency",
        "power_efficiency_radiated",
        "range_resolution_m",
        "blind_range_m",
        "snr_loss_db",
        "mainlobe_peak_db",
    )
    a.text(
        0.0,
        1.0,
        "\n".join(f"{k:26s} {m[k]:10.3f}" for k in keys if m.get(k) is not None),
        family="monospace",
        fontsize=9,
        va="top",
    )
    fig.suptitle(
        f"{Path(str(m['graph'])).name}: waveform {', '.join(m['waveforms'])}, filter {m['filter']}"
    )
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    write_atomic(path, buf.getvalue())


class WaveformCommand:
    """The ``pasim waveform`` subcommand (registered as a ``pasim_graph.commands`` plugin)."""

    help = "range sidelobes, efficiency and resolution of a graph's waveform, amplifier and filter"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("graph", help="graph file (YAML), e.g. graphs/waveform_nlfm.yaml")
        add_graph_arguments(parser)
        parser.add_argument("--json", action="store_true", help="print the figures as JSON")
        parser.add_argument(
            "--plot", metavar="FILE.png", help="plot envelopes, spectra and filter outputs"
        )
        parser.add_argument(
            "--filter", metavar="BLOCK", help="the receive filter, when the graph has several"
        )

    def run(self, args: argparse.Namespace) -> int:
        graph = load_graph(args)
        return report(
            args,
            lambda: analyse(graph, args.filter),
            lambda analysis: analysis.metrics,
            plot=plot,
            where=args.graph,
            errors=(ChainError,),
        )


COMMAND = WaveformCommand()
