"""``pasim pattern``: the antenna of a graph, measured as an antenna engineer would.

Azimuth and elevation cuts through the beam (one-way, H and V, co- and cross-polar), the
3-dB beamwidths, first and peak sidelobes, peak gain, the peak cross-polar level in the main
beam and the two-way H/V ratio at the peak (the ZDR bias the pattern causes), for the array
as built (channel errors drawn from ``--seed``, as ``pasim run --seed`` draws them) and, when
it has electronics, for the ideal array beside it. The measuring is
:mod:`pasim_blocks.antennas.beam_figures`; this module parses, calls and prints.
"""

from __future__ import annotations

import argparse
import io
import math
from typing import Any

import numpy as np

from pasim_graph.command_api import UserError, add_graph_arguments, load_graph, parse_seed
from pasim_graph.outputs import write_atomic
from pasim_graph.serialize import json_safe

from ..antennas.beam_figures import antenna_blocks, build, measure_as_built, measure_beams
from ..scans.scan import scan_beams
from .reporting import report


def _steer(text: str) -> tuple[float, float]:
    try:
        az, el = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected AZ,EL in degrees (e.g. 30,0), found {text!r}"
        ) from None
    if not (math.isfinite(az) and math.isfinite(el)) or abs(el) >= 90:
        raise argparse.ArgumentTypeError(f"AZ,EL must be finite with |EL| < 90, found {text!r}")
    return az, el


def _span(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected degrees, found {text!r}") from None
    if not 0.5 <= value <= 180:
        raise argparse.ArgumentTypeError(f"--span must be in [0.5, 180] deg, found {value}")
    return value


class PatternCommand:
    help = "measure a graph's antenna pattern: beamwidths, sidelobes, gain, cross-pol, ZDR bias"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("graph", help="graph file")
        parser.add_argument(
            "--steer",
            type=_steer,
            default=(0.0, 0.0),
            metavar="AZ,EL",
            help="beam direction in degrees from the array's broadside (default 0,0)",
        )
        parser.add_argument(
            "--seed",
            type=parse_seed,
            default=0,
            help="run seed that draws the channel errors, as `pasim run --seed` (default 0)",
        )
        parser.add_argument("--block", help="the antenna block, when the graph has several")
        parser.add_argument(
            "--span",
            type=_span,
            default=90.0,
            help="half-width of the azimuth and elevation cuts, degrees (default 90)",
        )
        parser.add_argument(
            "--scan",
            action="store_true",
            help="every beam of the graph's scan, steered as a run steers it: one row per beam "
            "(azimuth and elevation in the radar's frame, not from broadside)",
        )
        parser.add_argument("--json", action="store_true", help="print the figures as JSON")
        parser.add_argument("--plot", metavar="FILE.png", help="plot the cuts to a PNG file")
        add_graph_arguments(parser)

    def run(self, args: argparse.Namespace) -> int:
        graph = load_graph(args)
        names = antenna_blocks(graph)
        if args.block:
            if args.block not in names:
                raise UserError(
                    f"--block {args.block}: not an antenna block of {args.graph} "
                    f"(antennas: {', '.join(names) or 'none'})"
                )
            names = [args.block]
        if not names:
            raise UserError(f"{args.graph}: no block outputs an antenna pattern")
        if len(names) > 1:
            raise UserError(f"{args.graph} has several antennas ({', '.join(names)}): use --block")
        name = names[0]
        if args.scan:
            if args.plot or args.steer != (0.0, 0.0):
                raise UserError("--scan measures every beam of the scan: drop --steer and --plot")
            return scan_report(graph, name, args)
        type_name = graph.classes[name].type_name
        calibration = (
            graph.value(name, "calibration")
            if "calibration" in graph.classes[name].params
            else "boresight"
        )

        def figures(measured: tuple[dict[str, Any], dict[str, Any] | None]) -> dict[str, Any]:
            built, ideal = measured
            out = {k: json_safe(v) for k, v in built.items() if k != "cuts"}
            out.update(
                antenna=name,
                type=type_name,
                steer_deg=list(args.steer),
                seed=args.seed,
                electronics="ideal" if ideal is None else "with errors",
                calibration=calibration,
            )
            if ideal is not None:
                out["ideal"] = {k: json_safe(v) for k, v in ideal.items() if k != "cuts"}
            return out

        return report(
            args,
            lambda: measure_as_built(
                build(graph, name), *args.steer, seed=args.seed, span_deg=args.span
            ),
            figures,
            plot=lambda m, path: plot(
                path, m[0], m[1], f"{args.graph}: {name}, steered {args.steer}"
            ),
            text=lambda f: figures_text(args.graph, args.steer, f),
            where=f"block {name!r} ({type_name})",
        )


def figures_text(graph_file: str, steer: tuple[float, float], figures: dict[str, Any]) -> str:
    """The figures of one beam as the lines ``pasim pattern`` prints."""
    lines = [
        f"{graph_file}: antenna {figures['antenna']!r} ({figures['type']}), beam at az "
        f"{figures['beam_azimuth_deg']:.2f}, el {figures['beam_elevation_deg']:.2f} deg "
        f"({steer[0]:g}, {steer[1]:g} from broadside), {figures['electronics']}"
    ]
    rows = [
        ("3-dB beamwidth, azimuth / elevation (deg)", "beamwidth_az_deg", "beamwidth_el_deg"),
        (
            "first sidelobe, azimuth / elevation (dB)",
            "first_sidelobe_db",
            "first_sidelobe_el_db",
        ),
        ("peak sidelobe, H / V (dB)", "peak_sidelobe_db", "peak_sidelobe_v_db"),
        (
            "peak cross-polar in the main beam, H / V port (dB)",
            "cross_pol_h_db",
            "cross_pol_v_db",
        ),
    ]
    for label, a, b in rows:
        lines.append(
            f"  {label:52s} {_fmt(figures[a])} / {_fmt(figures[b])}" + _ideal_note(figures, a, b)
        )
    lines.append(
        f"  {'peak gain (dBi)':52s} {_fmt(figures['peak_gain_dbi'])}"
        + _ideal_note(figures, "peak_gain_dbi")
    )
    lines.append(
        f"  {'ZDR bias: two-way H/V ratio at the peak (dB)':52s} "
        f"{_fmt(figures['zdr_bias_db'])}" + _ideal_note(figures, "zdr_bias_db")
    )
    return "\n".join(lines)


def _fmt(v: Any) -> str:
    return "n/a" if v is None else f"{v:.3f}"


def _ideal_note(figures: dict[str, Any], *keys: str) -> str:
    if "ideal" not in figures:
        return ""
    return "   (ideal " + " / ".join(_fmt(figures["ideal"][k]) for k in keys) + ")"


def plot(path: str, built: dict[str, Any], ideal: dict[str, Any] | None, title: str) -> None:
    """Azimuth and elevation cuts (dB, one-way, relative to the ideal peak), as the paper's
    figures 3d-e and 5."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    reference = (ideal or built)["cuts"]["azimuth"][1]["h_co"].max()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, key in zip(axes, ("azimuth", "elevation"), strict=True):
        with np.errstate(divide="ignore"):
            if ideal is not None:
                d, c = ideal["cuts"][key]
                ax.plot(
                    d,
                    10 * np.log10(c["h_co"] / reference),
                    color="0.6",
                    lw=1.0,
                    label="H co-polar, ideal",
                )
            d, c = built["cuts"][key]
            label = "with errors" if ideal is not None else ""
            ax.plot(
                d,
                10 * np.log10(c["h_co"] / reference),
                color="C0",
                lw=0.8,
                label=f"H co-polar {label}".strip(),
            )
            ax.plot(
                d,
                10 * np.log10(c["v_co"] / reference),
                color="C1",
                lw=0.8,
                alpha=0.8,
                label=f"V co-polar {label}".strip(),
            )
            for comp, color in (("h_cross", "C2"), ("v_cross", "C3")):
                if np.any(c[comp] > 0):
                    ax.plot(
                        d,
                        10 * np.log10(c[comp] / reference),
                        color=color,
                        lw=0.6,
                        ls=":",
                        label=f"{comp[0].upper()} cross-polar",
                    )
        ax.set_xlabel(f"{key} from the beam axis (deg)")
        ax.set_ylim(-70, 3)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("one-way power (dB, ideal peak = 0)")
    axes[1].legend(loc="upper right", fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=130)
    plt.close(fig)
    write_atomic(path, buf.getvalue())


COMMAND = PatternCommand()


#: Figures of a per-scan table: (JSON key, column title, format).
SCAN_COLUMNS = (
    ("beamwidth_az_deg", "bw az", "{:.2f}"),
    ("beamwidth_el_deg", "bw el", "{:.2f}"),
    ("first_sidelobe_db", "1st SL", "{:.1f}"),
    ("peak_sidelobe_db", "peak SL", "{:.1f}"),
    ("peak_gain_dbi", "gain dBi", "{:.2f}"),
    ("zdr_bias_db", "H/V dB", "{:.3f}"),
)


def scan_report(graph: Any, name: str, args: argparse.Namespace) -> int:
    """``pasim pattern --scan``: the figures of every beam of the graph's one scan
    (:func:`~pasim_blocks.scans.scan.scan_beams`), each measured as ``--steer`` would
    (:func:`~pasim_blocks.antennas.beam_figures.measure_beams`)."""
    scans = graph.by_role("scan")
    if len(scans) != 1:
        raise UserError(f"--scan needs one scan block; the graph has {len(scans) or 'none'}")

    def figures(rows: list[dict[str, Any]]) -> dict[str, Any]:
        keep = ("azimuth_deg", "elevation_deg", "steer_deg", *(k for k, _, _ in SCAN_COLUMNS))
        # NaN figures (no first sidelobe in a short span) are None: "n/a" in the table.
        beams = [json_safe({k: r[k] for k in keep}) for r in rows]
        return {"antenna": name, "seed": args.seed, "beams": beams}

    return report(
        args,
        lambda: measure_beams(
            build(graph, name), scan_beams(graph, scans[0]), seed=args.seed, span_deg=args.span
        ),
        figures,
        text=lambda f: scan_text(f["beams"]),
        where=f"block {name!r} ({graph.classes[name].type_name})",
    )


def scan_text(rows: list[dict[str, Any]]) -> str:
    """The beams of ``pasim pattern --scan`` as a table, one line per beam."""
    head = ["az deg", "el deg", *(title for _, title, _ in SCAN_COLUMNS)]
    lines = ["  ".join(f"{h:>9}" for h in head)]
    for r in rows:
        cells = [f"{r['azimuth_deg']:.2f}", f"{r['elevation_deg']:.2f}"]
        cells += ["n/a" if r[k] is None else fmt.format(r[k]) for k, _, fmt in SCAN_COLUMNS]
        lines.append("  ".join(f"{c:>9}" for c in cells))
    return "\n".join(lines)
