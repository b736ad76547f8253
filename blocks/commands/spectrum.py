"""``pasim spectrum GRAPH``: the radiated pulse's spectrum against the NTIA RSEC mask.

The analysis is :mod:`pasim_blocks.transmitters.radiated` (its docstring says how the chain
is found and sampled); this module parses, calls, plots and prints. The radar's category is
``--category`` (default D), its peak power the graph's ``peak_power_w`` or ``--peak-power-w``.
"""

from __future__ import annotations

import argparse
import io
import math
from pathlib import Path

import numpy as np

from pasim_graph.command_api import UserError, add_graph_arguments, load_graph
from pasim_graph.outputs import write_atomic

from ..transmitters.emission import CRITERIA
from ..transmitters.radiated import Spectrum, analyse
from ..waveforms.chain import ChainError
from .reporting import report


def plot(s: Spectrum, path: str) -> None:
    """The radiated and drive spectra with the mask, and the radiated envelope."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = s.metrics
    fig, ax = plt.subplots(1, 2, figsize=(14, 5), gridspec_kw={"width_ratios": [2.2, 1]})
    a = ax[0]
    f_mhz = s.freq_hz / 1e6
    a.plot(f_mhz, s.drive_db, color="0.6", lw=0.8, label="drive (ideal amplifier)")
    a.plot(f_mhz, s.radiated_db, color="C0", lw=0.8, label="radiated")
    a.plot(
        f_mhz, s.mask_db, color="C3", lw=1.5, label=f"RSEC {m['category']} mask ({m['criterion']})"
    )
    for edge in (m["bandwidth_40_low_hz"], m["bandwidth_40_high_hz"]):
        a.axvline(edge / 1e6, color="C0", ls=":", lw=1)
    span = min(
        f_mhz[-1],
        1.2
        * m["bandwidth_40_allowed_hz"]
        / 2e6
        * 10 ** ((m["spurious_db"] - 40) / m["rolloff_db_per_decade"]),
    )
    verdict = "passes" if m["passes"] else "fails"
    a.set(
        xlim=(-span, span),
        ylim=(-m["spurious_db"] - 30, 3),
        xlabel="offset from the carrier (MHz)",
        ylabel="power spectral density (dB below peak)",
        title=(
            f"-40 dB bandwidth {m['bandwidth_40_hz'] / 1e6:.3g} MHz, allowed "
            f"{m['bandwidth_40_allowed_hz'] / 1e6:.3g} MHz: {verdict}, margin "
            f"{m['margin_db']:.1f} dB"
        ),
    )
    a.legend(fontsize=8, loc="upper right")
    a = ax[1]
    env = s.radiated["envelope"].values
    t_us = np.arange(env.size) / m["analysis_sample_rate_hz"] * 1e6
    drive = s.drive["envelope"].values
    a.plot(
        np.arange(drive.size) / float(s.drive.attrs["sample_rate_hz"]) * 1e6,
        np.abs(drive),
        color="0.6",
        label="drive",
    )
    a.plot(t_us, np.abs(env), color="C0", ls="--", label="radiated")
    a.set(
        xlabel="time (us)",
        ylabel="amplitude (1 = rated peak)",
        title=f"rise {m['rise_time_s'] * 1e6:.3g} us, fall {m['fall_time_s'] * 1e6:.3g} us",
    )
    a.legend(fontsize=8, loc="lower center")
    fig.suptitle(
        f"{Path(str(m['graph'])).name}: {', '.join(m['waveforms'])} through "
        f"{' + '.join(m['amplifiers']) or 'no amplifier'}, {m['peak_power_w'] / 1e3:g} kW peak"
    )
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    write_atomic(path, buf.getvalue())


class SpectrumCommand:
    """The ``pasim spectrum`` subcommand (registered as a ``pasim_graph.commands`` plugin)."""

    help = "the radiated pulse's spectrum, -40 dB bandwidth and NTIA RSEC emission mask"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("graph", help="graph file (YAML), e.g. graphs/generic_radar.yaml")
        add_graph_arguments(parser)
        parser.add_argument("--json", action="store_true", help="print the figures as JSON")
        parser.add_argument("--plot", metavar="FILE.png", help="plot the spectra and the mask")
        parser.add_argument(
            "--category",
            choices=sorted(CRITERIA),
            default="D",
            help="RSEC criteria category of the radar (default D)",
        )
        parser.add_argument(
            "--peak-power-w",
            type=float,
            metavar="W",
            help="peak power (default: the graph's peak_power_w parameter)",
        )
        parser.add_argument(
            "--sample-rate-hz",
            type=float,
            metavar="HZ",
            help="analysis sample rate (default: wide enough for the mask's spurious level)",
        )

    def run(self, args: argparse.Namespace) -> int:
        for flag, value in (
            ("--peak-power-w", args.peak_power_w),
            ("--sample-rate-hz", args.sample_rate_hz),
        ):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise UserError(f"{flag} {value:g}: expected a positive number")
        graph = load_graph(args)
        return report(
            args,
            lambda: analyse(graph, args.category, args.peak_power_w, args.sample_rate_hz),
            lambda result: result.metrics,
            plot=plot,
            where=args.graph,
            errors=(ChainError, ValueError),
        )


COMMAND = SpectrumCommand()
