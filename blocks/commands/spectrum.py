"""``pasim spectrum GRAPH``: the radiated pulse's spectrum against the NTIA RSEC mask.

The command finds the transmit chain as ``pasim waveform`` does (by port kinds: the
waveforms upstream of the receive filter, and the amplifiers that take and emit a pulse) and
runs only the waveform and amplifier blocks, through their public API, at an analysis sample
rate wide enough to see the mask down to its spurious level: the waveform blocks that have a
``sample_rate_hz`` parameter are re-run at that rate, so the envelope, the amplifier's
distortion and its rise and fall edges are sampled finely (a waveform without the parameter,
e.g. ``waveform.file``, is used at its own rate, and the span is limited to it). The drive
(every amplifier replaced by a wire) is computed too, for comparison.

The spectrum, the -40 dB bandwidth and the mask are those of
:mod:`pasim_blocks.transmitters.emission` (whose constants are unverified: see its docstring
and docs/transceiver.md). The radar's category (``--category``, default D) and its peak power
(a block parameter ``peak_power_w`` of the graph, or ``--peak-power-w``) choose the criteria;
an FM waveform is one whose pulse carries a ``bandwidth_hz`` (its swept bandwidth B_c).
"""

from __future__ import annotations

import argparse
import io
import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Chunk, Graph
from pasim_graph.outputs import write_atomic
from pasim_graph.serialize import json_safe

from ..transmitters.emission import (
    CRITERIA,
    bandwidth_at,
    compliance,
    mask_db,
    mask_span_hz,
    power_spectrum,
    rise_fall_times,
    rsec_criteria,
)
from .waveform import PULSE_KIND, ChainError, find_chain, metrics_text

#: The analysis span exceeds the mask's reach to the spurious level by this factor.
SPAN_MARGIN = 2.0
#: At most this many samples in the analysed pulse (bounds memory and time).
MAX_SAMPLES = 1 << 21


@dataclass
class Spectrum:
    """What ``pasim spectrum`` reports and plots."""

    metrics: dict[str, Any]
    drive: xr.Dataset  # the waveform through ideal amplifiers
    radiated: xr.Dataset  # through the graph's amplifiers
    freq_hz: np.ndarray
    radiated_db: np.ndarray
    drive_db: np.ndarray
    mask_db: np.ndarray


def transmit_pulses(graph: Graph, rate_hz: float | None) -> tuple[xr.Dataset, xr.Dataset, Any]:
    """The drive and the radiated pulse, the waveforms re-run at ``rate_hz`` (None: as is)."""
    chain = find_chain(graph)
    if not chain.amplifiers and len(chain.waveforms) != 1:
        raise ChainError(f"{len(chain.waveforms)} waveforms and no amplifier: which is radiated?")
    blocks = [n for n in chain.order if n in chain.waveforms or n in chain.amplifiers]
    out: dict[bool, dict[tuple[str, str], Any]] = {}
    for ideal in (True, False):
        values: dict[tuple[str, str], Any] = {}
        for name in blocks:
            cls = graph.classes[name]
            inputs = {e.dst_port: values[(e.src, e.src_port)] for e in graph.inputs_of(name)}
            if ideal and name in chain.amplifiers:
                result = {p.name: next(iter(inputs.values())) for p in cls.outputs.values()}
            else:
                params = dict(graph.params[name])
                if (
                    name in chain.waveforms
                    and rate_hz is not None
                    and "sample_rate_hz" in cls.params
                ):
                    params["sample_rate_hz"] = rate_hz
                what = f"block '{name}' ({cls.type_name})"
                try:
                    block = cls(name=name, **params)
                    result = block.process(
                        inputs,
                        Chunk(beams=np.arange(0), block_name=name, resource=block.load()),
                    )
                except Exception as exc:
                    raise ChainError(f"{what} failed: {type(exc).__name__}: {exc}") from None
            for port, value in result.items():
                values[(name, port)] = value
        out[ideal] = values
    # The radiated pulse: the output of the amplifier no other amplifier takes.
    last = [
        a
        for a in chain.amplifiers
        if not any(e.src == a and e.dst in chain.amplifiers for e in graph.edges)
    ]
    if len(last) > 1:
        raise ChainError(f"several final amplifiers ({', '.join(last)}): which is radiated?")
    source = last[0] if last else chain.waveforms[0]
    port = next(p.name for p in graph.classes[source].outputs.values() if p.type.kind == PULSE_KIND)
    # The drive: what the same stage emits when every amplifier is a wire.
    return out[True][(source, port)], out[False][(source, port)], chain


def graph_peak_power(graph: Graph) -> float | None:
    """The ``peak_power_w`` parameter of the graph's block that has one (None: none)."""
    found = [
        float(graph.params[n].get("peak_power_w", c.params["peak_power_w"].default))
        for n, c in graph.classes.items()
        if "peak_power_w" in c.params
    ]
    return found[0] if found else None


def _criteria_for(pulse: xr.Dataset, category: str, peak_w: float) -> tuple[Any, dict[str, Any]]:
    fs = float(pulse.attrs["sample_rate_hz"])
    env = pulse["envelope"].values
    rise, fall = rise_fall_times(env, fs)
    width = env.size / fs
    chirp = pulse.attrs.get("bandwidth_hz")
    crit = rsec_criteria(category, width, min(rise, fall), peak_w, chirp)
    return crit, {
        "width_s": width,
        "rise_time_s": rise,
        "fall_time_s": fall,
        "chirp_bandwidth_hz": chirp,
    }


def analyse(
    graph: Graph,
    category: str = "D",
    peak_power_w: float | None = None,
    rate_hz: float | None = None,
) -> Spectrum:
    """The radiated spectrum, its -40 dB bandwidth and the RSEC mask with the margin."""
    peak = peak_power_w if peak_power_w is not None else graph_peak_power(graph)
    if peak is None:
        raise ChainError("no block of the graph has a peak_power_w: give --peak-power-w")
    if rate_hz is None:
        # A first pass at the graph's own rates gives the criteria, hence the span needed.
        _, first, _ = transmit_pulses(graph, None)
        crit, _ = _criteria_for(first, category, peak)
        native = float(first.attrs["sample_rate_hz"])
        rate_hz = max(native, 2 * SPAN_MARGIN * mask_span_hz(crit))
        width = first["envelope"].size / native
        if width * rate_hz > MAX_SAMPLES:
            rate_hz = MAX_SAMPLES / width
    drive, radiated, chain = transmit_pulses(graph, rate_hz)
    crit, shape = _criteria_for(radiated, category, peak)
    fs = float(radiated.attrs["sample_rate_hz"])
    f, level = power_spectrum(radiated["envelope"].values, fs)
    _, drive_level = power_spectrum(drive["envelope"].values, float(drive.attrs["sample_rate_hz"]))
    measured = bandwidth_at(f, level)
    verdict = compliance(f, level, crit)
    metrics: dict[str, Any] = {
        "graph": graph.spec.file,
        "waveforms": chain.waveforms,
        "amplifiers": chain.amplifiers,
        "category": category,
        "peak_power_w": peak,
        "fm": shape["chirp_bandwidth_hz"] is not None,
        **shape,
        "analysis_sample_rate_hz": fs,
        "bandwidth_40_hz": measured["bandwidth_hz"],
        "bandwidth_40_low_hz": measured["low_hz"],
        "bandwidth_40_high_hz": measured["high_hz"],
        "bandwidth_40_allowed_hz": crit.bandwidth_40_hz,
        "criterion": crit.formula,
        "k": crit.k,
        "rolloff_db_per_decade": crit.slope_db_per_decade,
        "spurious_db": crit.spurious_db,
        "passes": verdict["passes"],
        "margin_db": verdict["margin_db"],
        "worst_offset_hz": verdict["worst_offset_hz"],
    }
    try:
        metrics["bandwidth_40_drive_hz"] = bandwidth_at(f, drive_level)["bandwidth_hz"]
    except ValueError:
        metrics["bandwidth_40_drive_hz"] = None
    return Spectrum(metrics, drive, radiated, f, level, drive_level, mask_db(f, crit))


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
        from pasim_graph.cli import add_graph_arguments

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
        from pasim_graph.cli import UserError, load_graph

        for flag, value in (
            ("--peak-power-w", args.peak_power_w),
            ("--sample-rate-hz", args.sample_rate_hz),
        ):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise UserError(f"{flag} {value:g}: expected a positive number")
        graph = load_graph(args)
        if args.plot and not Path(args.plot).resolve().parent.is_dir():
            raise UserError(f"--plot {args.plot}: the directory does not exist")
        try:
            result = analyse(graph, args.category, args.peak_power_w, args.sample_rate_hz)
        except (ChainError, ValueError) as exc:
            raise UserError(f"{args.graph}: {exc}") from None
        if args.plot:
            try:
                plot(result, args.plot)
            except (OSError, ValueError) as exc:
                raise UserError(f"--plot {args.plot}: {exc}") from None
        if args.json:
            print(json.dumps({k: json_safe(v) for k, v in result.metrics.items()}, indent=2))
        else:
            print(metrics_text(result.metrics))
        if args.plot:
            print(f"wrote {args.plot}", file=sys.stderr)
        return 0


COMMAND = SpectrumCommand()
