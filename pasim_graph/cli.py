"""The ``pasim`` command line.

Every user error (a broken graph, a missing file, a bad option) prints a message naming the
culprit and exits with code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import errno
import gc
import json
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any

from . import __version__, registry
from .block import RunNote
from .block_reference import cmd_blocks
from .command_api import (
    UserError,
    add_graph_arguments,
    graph_and_overrides,
    load_graph,
    parse_seed,
)
from .contracts import ScoringCommand
from .graph import Graph, GraphError
from .interrupt import StopMessage, Stopped, stop_on_signals
from .outputs import write_atomic
from .serialize import json_safe

EXIT_USAGE = 2


def cmd_validate(args: argparse.Namespace) -> int:
    try:
        graph = load_graph(args)
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


def cmd_run(args: argparse.Namespace) -> int:
    from .cluster import SchedulerError, check_scheduler
    from .dask_executor import DaskExecutor, ResourceError, ResumeError
    from .executor import BlockError, RunOptions
    from .provenance import run_attrs
    from .scores import print_volume, volume_scores
    from .steering import SteeringError
    from .store import StoreError, StoreExistsError, open_volume

    graph = load_graph(args)
    out = Path(args.out)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if args.workers and cores and args.workers > cores:
        # Each worker is a process running one chunk at a time on one core: more workers than
        # cores only add processes competing for them (1,000 on 2 cores ran until killed).
        raise UserError(
            f"--workers {args.workers}: this machine gives the run {cores} cores; use at most "
            f"{cores} (or --scheduler ADDRESS for a cluster's workers)"
        )
    if args.scheduler:
        try:
            check_scheduler(args.scheduler)
        except SchedulerError as exc:
            raise UserError(str(exc)) from None
    options = RunOptions(
        seed=args.seed,
        chunk_beams=args.chunk or 8,
        save_iq=args.save_iq,
        fields=_fields(args.outputs, graph),
    )
    command = " ".join(["pasim", *sys.argv[1:]]) if sys.argv else "pasim run"
    attrs = {
        **run_attrs(graph.text(), str(args.graph), Path(args.graph).stem, command),
        "seed": args.seed,
    }
    t0 = time.perf_counter()
    try:
        executor = DaskExecutor(
            graph,
            options,
            workers=args.workers,
            scheduler=args.scheduler,
            progress=args.progress or sys.stderr.isatty(),
            chunk_auto=args.chunk is None,
        )
        if args.resume:
            executor.adopt_chunking(out)
        n = sum(s.plan.beam_count for s in executor.sweeps)
        sweeps = f" in {len(executor.sweeps)} sweeps" if len(executor.sweeps) > 1 else ""
        print(
            f"running {args.graph}: {n} beams{sweeps} in chunks of "
            f"{executor.options.chunk_beams}, seed {args.seed}",
            file=sys.stderr,
        )
        with stop_on_signals():
            report = executor.run(
                out,
                attrs,
                resume=args.resume,
                overwrite=args.overwrite,
                command=command,
                log=lambda s: print(s, file=sys.stderr),
            )
    except Stopped as exc:
        raise StopMessage(_stopped_run(exc, out), exc.exit_code) from None
    except BlockError as exc:
        if args.debug:
            raise
        raise UserError(f"{args.graph}: {exc} (rerun with --debug for the traceback)") from None
    except SteeringError as exc:
        raise UserError(str(exc)) from None
    except (StoreError, StoreExistsError, ResumeError, ResourceError, SchedulerError) as exc:
        raise UserError(f"{out}: {exc}" if isinstance(exc, SchedulerError) else str(exc)) from None
    dt = time.perf_counter() - t0
    print(
        f"wrote {out} in {dt:.1f} s (set-up {report.seconds_setup:.1f} s, {report.chunks_run} "
        f"of {report.chunks_total} chunks in {report.seconds_chunks:.1f} s)",
        file=sys.stderr,
    )
    # The table is the product: on standard output, so `pasim run ... > scores.txt` keeps it.
    print_volume(volume_scores(open_volume(out)), sys.stdout)
    return 0


def _stopped_run(exc: Stopped, out: Path) -> str:
    """One line: what a stopped run finished and how to go on."""
    from .store import is_store, run_state

    state = run_state(out) if out.exists() and is_store(out) else None
    if state is None:
        return f"stopped by {exc}: nothing was written to {out}; run it again"
    done, total = int(state[1].sum()), state[1].size
    return (
        f"stopped by {exc}: {done} of {total} chunks of {out} are written and kept; "
        "complete them with the same command and --resume"
    )


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

    graph, overrides = graph_and_overrides(args)
    labels = None
    if args.levels is not None:
        labels = [x.strip() for x in args.levels.split(",") if x.strip()]
        if not labels:
            try:
                known = ", ".join(r.label for r in ladder(graph))
            except TradeoffError as exc:
                raise UserError(f"{args.graph}: {exc}") from None
            raise UserError(f"--levels: no level given; the levels of this graph are {known}")
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
        print(json.dumps(json_safe(rows), indent=1))
    else:
        print(format_table(rows, keys))
    return 0


def cmd_score(args: argparse.Namespace) -> int:
    from .scores import print_volume, volume_scores
    from .store import NotAStoreError, open_finished

    if args.sweep is not None and not (args.against or args.by):
        raise UserError(
            "--sweep goes with --against or --by; pasim score alone scores every sweep and the "
            "volume"
        )
    if args.sweep is not None and args.sweep < 0:
        raise UserError(f"--sweep {args.sweep}: expected a sweep number >= 0")
    if args.against or args.by:
        # Against another store or per azimuth: the radar scoring is the block library's
        # (its `compare` command), reached through the plugin registry.
        command = registry.commands().get("compare")
        if not isinstance(command, ScoringCommand):
            raise UserError(
                "--against and --by need the block library's `compare` command (a "
                "pasim_graph.contracts.ScoringCommand)"
            )
        return int(command.score(args))
    try:
        # refuses, naming it, a store that is missing, unfinished or damaged
        volume = volume_scores(open_finished(args.store))
    except NotAStoreError as exc:
        raise UserError(str(exc)) from None
    if not volume["scores"]:
        raise UserError(f"{args.store}: holds no scored fields (the graph had no scorer)")
    if args.json:
        # One sweep: its scores by moment, as always; a volume: each sweep's and the pooled.
        one = len(volume["sweeps"]) == 1
        if one:
            # A moment the truth does not hold is listed as such, never left out silently.
            missing = {n: {"no_truth": True, "count": 0} for n in volume["no_truth"]}
            print(json.dumps(json_safe({**volume["scores"], **missing}), indent=2))
        else:
            print(json.dumps(json_safe(volume), indent=2))
    else:
        print_volume(volume, sys.stdout)
    return 0


def parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The command line's parser; with ``argv``, plugin commands load only if it may need them
    (so ``pasim --version`` and ``pasim run ...`` never import a plugin package)."""
    ap = argparse.ArgumentParser(
        prog="pasim",
        description="Phased-array weather radar simulator: run block graphs on real radar data.",
    )
    ap.add_argument("--version", action="version", version=f"pasim-graph {__version__}")
    sub = ap.add_subparsers(dest="command", required=True)

    run = sub.add_parser(
        "run",
        help="run a graph and write a Zarr radar volume",
        description="Run a graph over its scan and write the estimated moments, the truth on "
        "the same grid and the errors to a CfRadial-2 Zarr store; print the scores.",
    )
    run.add_argument("graph", help="graph file (YAML), e.g. graphs/generic_radar.yaml")
    add_graph_arguments(run)
    run.add_argument(
        "--seed",
        type=parse_seed,
        default=0,
        help="random seed, a whole number >= 0 (default 0): the same graph, seed and sector "
        "give the same numbers whatever the chunking",
    )
    run.add_argument(
        "--chunk",
        type=_positive("--chunk"),
        metavar="BEAMS",
        help="beams per chunk, >= 1 (default: at most 8, fewer when that balances the "
        "workers better; a resumed store keeps its own; does not change the results)",
    )
    run.add_argument("--save-iq", action="store_true", help="also store the H and V I/Q cubes")
    run.add_argument(
        "--outputs",
        metavar="FIELD[,FIELD...]",
        help="compute and store only these fields (e.g. DBZH); blocks skip the rest",
    )
    run.add_argument(
        "--out",
        required=True,
        metavar="STORE",
        help="output store, a directory (e.g. run.zarr); must not exist, be empty, or be a "
        "store this program wrote (with --resume or --overwrite)",
    )
    again = run.add_mutually_exclusive_group()
    again.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an existing store of this program's (anything else is refused)",
    )
    again.add_argument(
        "--resume",
        action="store_true",
        help="complete an interrupted run (same graph, seed, chunk size)",
    )
    where = run.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=_positive("--workers"),
        metavar="N",
        help="run on a dask.distributed LocalCluster of N worker processes",
    )
    where.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="'threads' (default: dask threads in this process), 'sync' (one chunk after "
        "another, for debugging) or an existing dask.distributed scheduler (tcp://host:8786)",
    )
    run.add_argument(
        "--progress", action="store_true", help="show a progress bar (shown anyway on a terminal)"
    )
    run.add_argument("--debug", action="store_true", help="show tracebacks of block failures")
    run.set_defaults(func=cmd_run)

    val = sub.add_parser("validate", help="check a graph without running it")
    val.add_argument("graph", help="graph file (YAML)")
    add_graph_arguments(val)
    val.add_argument("--json", action="store_true", help="print the result as JSON")
    val.set_defaults(func=cmd_validate)

    blk = sub.add_parser("blocks", help="list the registered block types")
    fmt = blk.add_mutually_exclusive_group()
    fmt.add_argument("--json", action="store_true", help="print the interfaces as JSON")
    fmt.add_argument(
        "--markdown", action="store_true", help="print the block reference as Markdown"
    )
    blk.set_defaults(func=cmd_blocks)

    tr = sub.add_parser(
        "tradeoff", help="run a graph at every fidelity level: time, memory and error of each"
    )
    tr.add_argument("graph", help="graph file (YAML)")
    add_graph_arguments(tr)
    tr.add_argument("--seed", type=parse_seed, default=0, help="random seed, >= 0 (default 0)")
    tr.add_argument(
        "--chunk", type=_positive("--chunk"), default=8, metavar="BEAMS", help="beams per chunk"
    )
    tr.add_argument(
        "--levels",
        metavar="LEVEL[,LEVEL...]",
        help="run only these levels of the graph's fidelity ladder (for the weather channel: "
        "expected, combined-40dB, combined, combined-f64, covariance, covariance-all, "
        "covariance-f64, monte_carlo); default: all",
    )
    tr.add_argument("--json", action="store_true", help="print a list of rows as JSON")
    tr.set_defaults(func=cmd_tradeoff)

    sc = sub.add_parser("score", help="print the error statistics stored in a run")
    sc.add_argument("store", help="a store written by `pasim run`")
    sc.add_argument("--json", action="store_true", help="print the scores as JSON")
    sc.add_argument("--against", metavar="REF.zarr", help="errors against another store's levels")
    sc.add_argument(
        "--sweep",
        type=int,
        metavar="N",
        help="with --against or --by: which sweep of a volume (without them every sweep is scored)",
    )
    sc.add_argument("--by", metavar="azimuth[:BIN]", help="a per-azimuth profile (BIN in deg)")
    sc.set_defaults(func=cmd_score)
    _add_studio_commands(sub)
    if _may_need_plugins(argv, set(sub.choices)):
        _add_plugin_commands(sub)
    return ap


def _may_need_plugins(argv: list[str] | None, builtin: set[str]) -> bool:
    """Whether parsing ``argv`` may need the plugin commands: unless it names a built-in
    command, or asks only for the version."""
    if argv is None:
        return True
    first = next((a for a in argv if not a.startswith("-")), None)
    if first is None:
        return "--version" not in argv
    return first not in builtin


def _positive(option: str) -> Any:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, found {text!r}") from None
        if value < 1:
            raise argparse.ArgumentTypeError(f"{option} must be at least 1, found {value}")
        return value

    return parse


def _add_plugin_commands(sub: Any) -> None:
    """Subcommands that packages register in the ``pasim_graph.commands`` entry-point group.

    Each entry point names a :class:`pasim_graph.command_api.Command` (``help``,
    ``configure(parser)``, ``run(args) -> int``); it raises :class:`UserError` for what the
    user can fix. The block
    library's ``pasim waveform`` and ``pasim pattern`` come this way, so the engine never
    imports it. A command that fails to load warns and is left out.
    """
    for name, command in registry.commands().items():
        if name in sub.choices:
            warnings.warn(
                f"command {name!r} of a plugin package clashes with a built-in; ignored",
                registry.PluginWarning,
                stacklevel=2,
            )
            continue
        parser = sub.add_parser(name, help=command.help, description=command.help)
        command.configure(parser)
        parser.set_defaults(func=command.run)


# -- studio and graph pictures (issue 17); their modules load only when used --


def cmd_studio(args: argparse.Namespace) -> int:
    from .studio.server import serve

    return serve(args.target, args.port, args.runs, args.open)


def cmd_graph(args: argparse.Namespace) -> int:
    from .graph_export import FORMATS, view

    graph = load_graph(args)
    text = FORMATS[args.format](view(graph.spec, Path(args.graph).stem))
    if args.out:
        write_atomic(args.out, text)
        print(f"wrote {args.out}", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0


def _add_studio_commands(sub: Any) -> None:
    st = sub.add_parser(
        "studio", help="edit, run and compare graphs in the browser (a local web page)"
    )
    st.add_argument("target", nargs="?", default=".", metavar="GRAPH | FOLDER")
    st.add_argument("--port", type=int, default=8765, help="port on 127.0.0.1 (0: any free one)")
    st.add_argument(
        "--runs", metavar="DIR", help="keep the runs' stores here (default: a temporary folder)"
    )
    st.add_argument("--open", action="store_true", help="open the page in the default browser")
    st.set_defaults(func=cmd_studio)

    gr = sub.add_parser("graph", help="a picture of a graph: SVG, Graphviz DOT or Mermaid")
    gr.add_argument("graph")
    gr.add_argument("--format", choices=["svg", "dot", "mermaid"], default="svg")
    gr.add_argument("--out", metavar="FILE", help="write to FILE instead of printing")
    gr.set_defaults(func=cmd_graph)


def _quiet_abandoned_io() -> None:
    """After a stop by signal, keep asyncio from reporting at exit the reads zarr had in
    flight when the signal came (their tasks are abandoned on purpose: the command ends)."""
    import logging

    logging.getLogger("asyncio").disabled = True


#: The notes and warnings already printed by this process: a study runs many graphs, each of
#: which may say the same thing (and dask or xarray reset the warnings registry between runs,
#: so the "default" filter alone printed a study's note once per run).
_SHOWN: set[str] = set()


def _show_warning(
    message: Warning | str, category: type[Warning], *args: Any, **kwargs: Any
) -> None:
    # Notes and plugin warnings are for users: one line each, no source location, once.
    label = "note" if issubclass(category, RunNote) else "warning"
    line = f"{label}: {message}"
    if line not in _SHOWN:
        _SHOWN.add(line)
        print(line, file=sys.stderr)


def _join_negative_values(argv: list[str]) -> list[str]:
    """``--sector -10:10`` as ``--sector=-10:10`` (and ``--steer -20,10``): argparse would
    take a value that starts with a minus sign for an option."""
    out: list[str] = []
    for i, arg in enumerate(argv):
        if out and out[-1] in ("--sector", "--steer") and arg.startswith("-") and i > 0:
            out[-1] = f"{out[-1]}={arg}"
            continue
        out.append(arg)
    return out


def program() -> int:
    """The ``pasim`` program: :func:`main`, then an exit without the interpreter's last
    garbage collections (the memory is the operating system's to free): they walk every
    object the numerical libraries and a run left, 0.37 s measured with a study's imports,
    0.04 s frozen. Not in :func:`main`, which tests call many times in one process."""
    code = main()
    gc.freeze()
    return code


def main(argv: list[str] | None = None) -> int:
    argv = _join_negative_values(list(sys.argv[1:] if argv is None else argv))
    _SHOWN.clear()  # each note once per command
    with warnings.catch_warnings():
        warnings.simplefilter("default", registry.PluginWarning)
        warnings.showwarning = _show_warning
        args = parser(argv).parse_args(argv)
    with warnings.catch_warnings():
        warnings.simplefilter("default", registry.PluginWarning)
        warnings.simplefilter("default", RunNote)
        warnings.showwarning = _show_warning
        try:
            code = int(args.func(args))
            # Flush here, not at the interpreter's exit: a full device (`> /dev/full`) is then
            # an error of this program, one line, not a traceback from the final flush.
            sys.stdout.flush()
            return code
        except GraphError as exc:
            print(exc.report(), file=sys.stderr)
        except UserError as exc:
            print(f"error: {exc}", file=sys.stderr)
        except MemoryError as exc:
            detail = f" ({exc})" if str(exc) else ""
            print(
                f"error: ran out of memory{detail}; use a smaller --chunk, fewer --workers, or "
                "--outputs to compute less",
                file=sys.stderr,
            )
        except StopMessage as exc:
            _quiet_abandoned_io()
            print(str(exc), file=sys.stderr)
            return exc.exit_code
        except KeyboardInterrupt:
            _quiet_abandoned_io()
            print("interrupted", file=sys.stderr)
            return 130
        except FileNotFoundError as exc:
            if exc.filename is None:
                raise
            # An output in a folder that does not exist (plot --out, graph --out, ...).
            where = Path(str(exc.filename)).parent
            why = f"the folder {where} does not exist" if not where.is_dir() else "no such file"
            print(f"error: {exc.filename}: {why}", file=sys.stderr)
        except BrokenPipeError:
            # The reader went away (`pasim score ... | head`): not an error of ours. Point
            # stdout at nothing so the interpreter's final flush cannot fail again.
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 0
        except OSError as exc:
            # An output that cannot be written: a read-only or full disk, a folder given as a
            # file. Outputs are written whole or not at all (outputs.write_atomic).
            if exc.filename is not None:
                print(f"error: {exc.filename}: cannot write: {exc.strerror}", file=sys.stderr)
            elif exc.errno in (errno.ENOSPC, errno.EIO, errno.EROFS, errno.EDQUOT):
                print(f"error: cannot write standard output: {exc.strerror}", file=sys.stderr)
                # What is still buffered cannot be written either: drop it with the stream.
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            else:
                raise
    return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
