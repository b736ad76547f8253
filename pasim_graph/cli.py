"""The ``pasim`` command line.

Every user error (a broken graph, a missing file, a bad option) prints a message naming the
culprit and exits with code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from pathlib import Path
from typing import Any

from . import __version__, registry
from .block import RunNote
from .graph import Graph, GraphError, parse_overrides, validate
from .graphfile import Problem, read

EXIT_USAGE = 2


class UserError(Exception):
    """A problem the user can fix; printed without a traceback."""


def _graph(args: argparse.Namespace) -> Graph:
    return _graph_and_overrides(args)[0]


def _graph_and_overrides(args: argparse.Namespace) -> tuple[Graph, dict[str, Any]]:
    """The validated graph and the overrides (``--set``, ``--truth``, ``--sector``) it got."""
    spec = read(args.graph)
    overrides, bad = parse_overrides(getattr(args, "set", None) or [])
    problems = [Problem(spec.file, 0, "", f"--set {b}", "expected BLOCK.PARAM=VALUE") for b in bad]
    roles: dict[str, list[str]] = {}
    for name, b in spec.blocks.items():
        cls = registry.get(b.type)
        if cls is not None and cls.role:
            roles.setdefault(cls.role, []).append(name)

    def by_role(role: str, option: str) -> str | None:
        names = roles.get(role, [])
        if len(names) != 1:
            problems.append(
                Problem(
                    spec.file,
                    0,
                    "",
                    option,
                    f"needs exactly one {role} block in the graph, found {len(names)}",
                )
            )
            return None
        return names[0]

    if getattr(args, "truth", None):
        block = by_role("truth", "--truth")
        if block:
            overrides.setdefault(f"{block}.path", str(args.truth))
    if getattr(args, "sector", None):
        block = by_role("scan", "--sector")
        try:
            a0, a1 = (float(x) for x in args.sector.split(":"))
        except ValueError:
            problems.append(
                Problem(
                    spec.file,
                    0,
                    "",
                    "--sector",
                    f"expected AZ0:AZ1 in degrees, found {args.sector!r}",
                )
            )
        else:
            if block:
                overrides[f"{block}.azimuth_start_deg"] = a0
                overrides[f"{block}.azimuth_stop_deg"] = a1
    try:
        graph = validate(spec, overrides)
    except GraphError as exc:
        raise GraphError(exc.problems + problems) from None
    if problems:
        raise GraphError(problems)
    sector = _truth_sector(graph)
    if sector:
        overrides |= sector
        graph = validate(spec, overrides)
    return graph, overrides


def _truth_sector(graph: Graph) -> dict[str, Any]:
    """Let a truth block that can read a sector read only the scan's (plus its margin).

    Applies when there is one truth and one scan block, both declare ``azimuth_start_deg`` and
    ``azimuth_stop_deg``, and the truth's sector is not set already.
    """
    keys = ("azimuth_start_deg", "azimuth_stop_deg")
    truth, scan = graph.by_role("truth"), graph.by_role("scan")
    if len(truth) != 1 or len(scan) != 1:
        return {}
    t, s = truth[0], scan[0]
    if not all(k in graph.classes[t].params and k in graph.classes[s].params for k in keys):
        return {}
    if any(graph.value(t, k) is not None for k in keys):
        return {}
    return {f"{t}.{k}": graph.value(s, k) for k in keys}


def cmd_validate(args: argparse.Namespace) -> int:
    try:
        graph = _graph(args)
    except GraphError as exc:
        if args.json:
            print(
                json.dumps(
                    {"valid": False, "problems": [p.to_json() for p in exc.problems]}, indent=2
                )
            )
            return EXIT_USAGE
        raise
    if args.json:
        print(json.dumps({"valid": True, **graph.to_json()}, indent=2))
    else:
        print(f"{args.graph}: valid ({len(graph.classes)} blocks, {len(graph.edges)} connections)")
    return 0


def cmd_blocks(args: argparse.Namespace) -> int:
    blocks = registry.all_blocks()
    if args.json:
        print(json.dumps([cls.interface() for cls in blocks.values()], indent=2, default=str))
        return 0
    for name, cls in blocks.items():
        print(f"{name}  ({cls.__name__}) {cls.doc()}")
        for p in cls.inputs.values():
            print(f"    in   {p.name}: {p.type.describe()}")
        for o in cls.outputs.values():
            print(f"    out  {o.name}: {o.type.describe()}")
        for q in cls.params.values():
            default = "required" if q.required else repr(q.default)
            print(f"    param {q.name} = {default} {q.units}  {q.doc}".rstrip())
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    from .dask_executor import DaskExecutor, ResumeError
    from .executor import BlockError, RunOptions
    from .store import StoreExistsError, open_volume, summarize

    graph = _graph(args)
    out = Path(args.out)
    if out.exists() and not (args.overwrite or args.resume):
        raise UserError(f"{out} exists; pass --resume to complete it or --overwrite to replace it")
    if args.chunk < 1:
        raise UserError(f"--chunk must be at least 1 beam, found {args.chunk}")
    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers must be at least 1, found {args.workers}")
    options = RunOptions(
        seed=args.seed,
        chunk_beams=args.chunk,
        save_iq=args.save_iq,
        fields=_fields(args.outputs, graph),
    )
    attrs = {
        "title": "PASIM-graph simulated radar volume",
        "Conventions": "Cf/Radial",
        "version": "2.0",
        "pasim_graph_version": __version__,
        "graph": graph.text(),
        "graph_file": str(args.graph),
        "seed": args.seed,
        "simulated": "true",
        "source": "PASIM-graph simulation",
    }
    t0 = time.perf_counter()
    try:
        executor = DaskExecutor(
            graph,
            options,
            workers=args.workers,
            scheduler=args.scheduler,
            progress=args.progress or sys.stderr.isatty(),
        )
        n = executor.local.plan.beam_count
        print(
            f"running {args.graph}: {n} beams in chunks of {args.chunk}, seed {args.seed}",
            file=sys.stderr,
        )
        report = executor.run(
            out,
            attrs,
            resume=args.resume,
            overwrite=args.overwrite,
            log=lambda s: print(s, file=sys.stderr),
        )
    except BlockError as exc:
        if args.debug:
            raise
        raise UserError(f"{args.graph}: {exc} (rerun with --debug for the traceback)") from None
    except (StoreExistsError, ResumeError) as exc:
        raise UserError(str(exc)) from None
    dt = time.perf_counter() - t0
    print(
        f"wrote {out} in {dt:.1f} s (set-up {report.seconds_setup:.1f} s, {report.chunks_run} "
        f"of {report.chunks_total} chunks in {report.seconds_chunks:.1f} s)",
        file=sys.stderr,
    )
    _print_scores(summarize(open_volume(out)["sweep_0"].to_dataset()), sys.stderr)
    return 0


def _fields(text: str | None, graph: Graph) -> tuple[str, ...] | None:
    """The ``--outputs`` list, checked against the fields the graph's stored outputs declare."""
    if text is None:
        return None
    asked = tuple(f.strip() for f in text.split(",") if f.strip())
    known: list[str] = []
    for cls in graph.classes.values():
        for port in cls.outputs.values():
            if port.store == "moments":
                known += [f for f in port.fields if f not in known]
    unknown = [f for f in asked if f not in known]
    if not asked or unknown:
        raise UserError(
            f"--outputs {text!r}: "
            + (f"unknown field(s) {', '.join(unknown)}; " if unknown else "no field given; ")
            + f"this graph produces {', '.join(known) or 'no declared fields'}"
        )
    return asked


def cmd_tradeoff(args: argparse.Namespace) -> int:
    from .tradeoff import TradeoffError, format_table, ladder, ladder_keys, tradeoff

    graph, overrides = _graph_and_overrides(args)
    labels = [x.strip() for x in args.levels.split(",")] if args.levels else None
    try:
        keys = ladder_keys(ladder(graph))
        rows = tradeoff(
            graph,
            str(args.graph),
            overrides,
            seed=args.seed,
            chunk=args.chunk,
            labels=labels,
            log=lambda s: print(s, file=sys.stderr),
        )
    except TradeoffError as exc:
        raise UserError(f"{args.graph}: {exc}") from None
    if args.json:
        print(json.dumps(_json_safe(rows), indent=1))
    else:
        print(format_table(rows, keys))
    return 0


def cmd_score(args: argparse.Namespace) -> int:
    from .store import IncompleteStoreError, open_volume, summarize

    try:
        tree = open_volume(args.store)
    except IncompleteStoreError as exc:
        raise UserError(str(exc)) from None
    except (FileNotFoundError, OSError, ValueError) as exc:
        raise UserError(f"{args.store}: cannot open store: {exc}") from None
    if "sweep_0" not in tree.children:
        raise UserError(f"{args.store}: no sweep_0 group; is this a PASIM-graph store?")
    scores = summarize(tree["sweep_0"].to_dataset())
    if not scores:
        raise UserError(f"{args.store}: holds no scored fields (the graph had no scorer)")
    if args.json:
        print(json.dumps(_json_safe(scores), indent=2))
    else:
        _print_scores(scores, sys.stdout)
    return 0


def _json_safe(x: Any) -> Any:
    """NaN (no estimate, nothing scored) becomes null: JSON has no NaN."""
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_json_safe(v) for v in x]
    return None if isinstance(x, float) and math.isnan(x) else x


def _print_scores(scores: dict[str, dict[str, Any]], stream: Any) -> None:
    if not scores:
        return
    print(
        f"{'moment':8} {'bias':>9} {'std':>9} {'count':>8}  {'req bias/std':>14}  pass", file=stream
    )
    for name, s in scores.items():
        req = f"{s['requirement_bias']:g}/{s['requirement_std']:g}"
        print(
            f"{name:8} {s['bias']:9.4f} {s['std']:9.4f} {s['count']:8d}  {req:>14}  "
            f"{'yes' if s['pass'] else 'no'}",
            file=stream,
        )
    first = next(iter(scores.values()))
    if first.get("scored"):
        print(f"scored gates: {first['scored']}", file=stream)
    n = first.get("scored_gates", first["count"])
    if n == 0:
        print(
            "no gate met the scoring rule: nothing to score (is the sector all masked?)",
            file=stream,
        )
        return
    for name, s in scores.items():
        if s.get("unestimated"):
            print(
                f"{name}: {s['unestimated']} of {n} scored gates have no estimate (undefined: "
                "noise-corrected power <= 0)",
                file=stream,
            )


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="pasim",
        description="Phased-array weather radar simulator: run block graphs on real radar data.",
    )
    ap.add_argument("--version", action="version", version=f"pasim-graph {__version__}")
    sub = ap.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a graph and write a Zarr radar volume")
    run.add_argument("graph")
    run.add_argument("--truth", help="truth radar file (NEXRAD Level-II)")
    run.add_argument("--sector", help="azimuth sector AZ0:AZ1 in degrees, clockwise")
    run.add_argument(
        "--set",
        action="append",
        metavar="BLOCK.PARAM=VALUE",
        help="override a block parameter (repeatable)",
    )
    run.add_argument("--seed", type=int, default=0)
    run.add_argument(
        "--chunk",
        type=int,
        default=8,
        metavar="BEAMS",
        help="beams per chunk (does not change the results)",
    )
    run.add_argument("--save-iq", action="store_true", help="also store the H and V I/Q cubes")
    run.add_argument(
        "--outputs",
        metavar="FIELD[,FIELD...]",
        help="compute and store only these fields (e.g. DBZH); blocks skip the rest",
    )
    run.add_argument("--out", required=True, help="output store (.zarr)")
    run.add_argument("--overwrite", action="store_true", help="replace an existing store")
    run.add_argument(
        "--resume",
        action="store_true",
        help="complete an interrupted run (same graph, seed, chunk size)",
    )
    run.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="run on a dask.distributed LocalCluster of N worker processes",
    )
    run.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on an existing dask.distributed cluster (tcp://host:8786)",
    )
    run.add_argument(
        "--progress", action="store_true", help="show a progress bar (shown anyway on a terminal)"
    )
    run.add_argument("--debug", action="store_true", help="show tracebacks of block failures")
    run.set_defaults(func=cmd_run)

    val = sub.add_parser("validate", help="check a graph without running it")
    val.add_argument("graph")
    val.add_argument("--set", action="append", metavar="BLOCK.PARAM=VALUE")
    val.add_argument("--truth")
    val.add_argument("--sector")
    val.add_argument("--json", action="store_true")
    val.set_defaults(func=cmd_validate)

    blk = sub.add_parser("blocks", help="list the registered block types")
    blk.add_argument("--json", action="store_true")
    blk.set_defaults(func=cmd_blocks)

    tr = sub.add_parser(
        "tradeoff", help="run a graph at every fidelity level: time, memory and error of each"
    )
    tr.add_argument("graph")
    tr.add_argument("--truth", help="truth radar file (NEXRAD Level-II)")
    tr.add_argument("--sector", help="azimuth sector AZ0:AZ1 in degrees, clockwise")
    tr.add_argument("--set", action="append", metavar="BLOCK.PARAM=VALUE")
    tr.add_argument("--seed", type=int, default=0)
    tr.add_argument("--chunk", type=int, default=8, metavar="BEAMS")
    tr.add_argument("--levels", metavar="LEVEL[,LEVEL...]", help="run only these levels")
    tr.add_argument("--json", action="store_true", help="print a list of rows as JSON")
    tr.set_defaults(func=cmd_tradeoff)

    sc = sub.add_parser("score", help="print the error statistics stored in a run")
    sc.add_argument("store")
    sc.add_argument("--json", action="store_true")
    sc.set_defaults(func=cmd_score)
    return ap


def _show_warning(
    message: Warning | str, category: type[Warning], *args: Any, **kwargs: Any
) -> None:
    # Notes and plugin warnings are for users: one line each, no source location.
    label = "note" if issubclass(category, RunNote) else "warning"
    print(f"{label}: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    with warnings.catch_warnings():
        warnings.simplefilter("default", registry.PluginWarning)
        warnings.simplefilter("default", RunNote)
        warnings.showwarning = _show_warning
        try:
            return int(args.func(args))
        except GraphError as exc:
            print(exc.report(), file=sys.stderr)
        except UserError as exc:
            print(f"error: {exc}", file=sys.stderr)
        except KeyboardInterrupt:
            print("interrupted", file=sys.stderr)
            return 130
    return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
