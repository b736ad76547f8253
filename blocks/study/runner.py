"""Run a study's stores in one process, resumably, and keep its folder safe.

``DIR/pasim-study.json`` marks a folder as a study's (written first, atomically, and kept
up to date as runs finish): a folder without it that holds anything is never written into.
Runs live in ``DIR/runs/SYSTEM/CASE/POINT/KIND-SEED.zarr``; a finished store is kept and
never recomputed, an unfinished one is completed with the executor's own ``resume``.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from pasim_graph.outputs import write_atomic

from .measuring import Measuring
from .model import Case, Study
from .plan import Run

MANIFEST = "pasim-study.json"
#: The manifest's record of the `pasim` process while the study's runs ran, one entry each
#: time they ran (start, stop, its CPU seconds in all its threads, the workers).
PROCESS = "process"


class StudyError(Exception):
    """A study that cannot go on (printed as one line, exit 2)."""


def digest(study: Study) -> str:
    return hashlib.sha256(study.text.encode()).hexdigest()[:16]


#: What a manifest of this program holds, and the type of each (a hand-edited or foreign
#: manifest is refused in one line, never a KeyError in the middle of a study).
MANIFEST_KEYS: dict[str, type] = {
    "format": str,
    "study_digest": str,
    "runs": dict,
    "beamwidths": dict,
}
MANIFEST_FORMAT = "pasim-study-manifest/1"


def read_manifest(path: Path) -> dict[str, Any]:
    """A study manifest, checked to be this program's: StudyError naming the file and what is
    wrong otherwise."""
    try:
        state = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise StudyError(f"{path}: unreadable study manifest ({exc})") from None
    problem = ""
    if not isinstance(state, dict):
        problem = f"a JSON {type(state).__name__}, not an object"
    else:
        missing = [k for k in MANIFEST_KEYS if k not in state]
        wrong = [
            f"{k!r} is a {type(state[k]).__name__}, not a {MANIFEST_KEYS[k].__name__}"
            for k in MANIFEST_KEYS
            if k in state and not isinstance(state[k], MANIFEST_KEYS[k])
        ]
        if missing:
            problem = f"no {', '.join(repr(k) for k in missing)}"
        elif wrong:
            problem = "; ".join(wrong)
        elif state["format"] != MANIFEST_FORMAT:
            problem = f"format {state['format']!r}, not {MANIFEST_FORMAT!r}"
        elif not all(isinstance(v, dict) for v in state["runs"].values()):
            problem = "'runs' holds entries that are not objects"
    if problem:
        raise StudyError(
            f"{path}: not a study manifest this program wrote ({problem}); the folder is left "
            "untouched: choose another --out"
        )
    return state


def take_folder(
    out: Path, study: Study, resume: bool, inputs: dict[str, Any] | None = None
) -> dict[str, Any]:
    """The study's manifest in ``out``, refusing a folder this program did not write, and
    (with ``--resume``) one begun on other inputs (:func:`.integrity.study_inputs`)."""
    from .integrity import STUDY_FILE, changed_inputs

    manifest = out / MANIFEST
    if out.exists() and not out.is_dir():
        raise StudyError(f"{out}: exists and is not a folder; choose another --out")
    if manifest.is_file():
        state = read_manifest(manifest)
        if not resume:
            raise StudyError(
                f"{out} holds a study already: complete it with --resume, or choose another --out"
            )
        added: list[int] = []
        if state.get("study_digest") != digest(study):
            added = added_seeds(state, study)
            if not added:
                raise StudyError(
                    f"{out}: the study file changed since this folder's study began "
                    f"({state.get('study_file')}) in more than added seeds; use another "
                    "--out for the new study"
                )
        before = state.get("inputs")
        if added and inputs is not None and isinstance(before, dict):
            # The study file itself changed by its seeds alone (checked above): every other
            # input must be as it was.
            files = {**(before.get("files") or {}), STUDY_FILE: inputs["files"][STUDY_FILE]}
            before = {**before, "files": files}
        why = changed_inputs(before, inputs) if inputs is not None else ""
        if why:
            raise StudyError(
                f"{out}: cannot resume this study: {why}; its finished runs would be mixed "
                "with runs of other inputs: use another --out for the new study"
            )
        if added:
            began = state.get("study_text", "")
            state = {
                **state,
                "study_file": study.file,
                "study_digest": digest(study),
                "study_text": study.text,
                "inputs": inputs if inputs is not None else state.get("inputs", {}),
                "seeds_added": [*state.get("seeds_added", []), {"seeds": added, "from": began}],
            }
            save(out, state)
            print(
                f"{out}: seed{'s' if len(added) > 1 else ''} {', '.join(map(str, added))} "
                "added to the study; its finished runs are kept",
                file=sys.stderr,
            )
        return dict(state)
    if out.exists() and any(out.iterdir()):
        raise StudyError(
            f"{out} is not empty and holds no study ({MANIFEST} missing); it is left untouched: "
            "choose another --out"
        )
    if not out.parent.is_dir():
        raise StudyError(f"{out}: the folder {out.parent} does not exist")
    out.mkdir(exist_ok=True)
    state = {
        "format": MANIFEST_FORMAT,
        "study_file": study.file,
        "study_digest": digest(study),
        "study_text": study.text,
        "inputs": inputs or {},
        "runs": {},
        "beamwidths": {},
    }
    write_atomic(manifest, json.dumps(state, indent=1))
    return state


def added_seeds(state: dict[str, Any], study: Study) -> list[int]:
    """The seeds ``study`` adds to the study a folder began (its manifest ``state``), when
    that is its only change: the same title, reference, systems, cases and sweeps, every seed
    it began with kept. [] for any other change (or none): adding seeds narrows a study's
    noise intervals without running again what it has (a run is the same run whatever
    seeds stand beside it: its key names its own seed only)."""
    from .model import parse_study

    began = parse_study(str(state.get("study_text", "")), str(state.get("study_file", "")))
    if began.problems or study.problems or not set(began.seeds) < set(study.seeds):
        return []
    if _design(began) != _design(study):
        return []
    return [s for s in study.seeds if s not in began.seeds]


def _design(study: Study) -> Any:
    """What a study computes except its seeds: its entries without their line numbers."""
    from dataclasses import asdict

    def strip(x: Any) -> Any:
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k not in _LINES}
        if isinstance(x, list):
            return [strip(v) for v in x]
        return x

    return strip(
        {k: v for k, v in asdict(study).items() if k not in ("file", "text", "seeds", "problems")}
    )


# Where an entry was written in the study file: not what it computes.
_LINES = ("line", "override_lines", "value_lines")


def save(out: Path, state: dict[str, Any]) -> None:
    write_atomic(out / MANIFEST, json.dumps(state, indent=1))


def finished(path: Path) -> bool:
    """A run's store is marked complete and holds every chunk and every array its layout
    lists (one that lost an array is run again with --resume, which writes the array again).

    Marked complete, not only every chunk done: a run in flight (a study's runs at once)
    has every chunk done a moment before its last write, and cannot be read until then."""
    from pasim_graph.store import COMPLETE, is_store, missing_arrays, run_state

    if not path.exists() or not is_store(path):
        return False
    state = run_state(path)
    return (
        state is not None
        and state[0].get(COMPLETE) == "true"
        and bool(state[1].all())
        and not missing_arrays(path)
    )


def unscored(study: Study, runs: list[Run], out: Path, scores: dict[str, Any]) -> list[str]:
    """A line for each system of ``study`` that ``scores`` holds nothing of, with how many
    of its runs finished (a case and point is scored once every run of it has)."""
    lines = []
    for system in study.systems:
        if scores.get(system.name):
            continue
        own = [r for r in runs if r.system == system.name]
        done = sum(finished(out / "runs" / r.key) for r in own)
        lines.append(
            f"system '{system.name}' is unscored: {done} of its {len(own)} runs finished "
            "(a case is scored once every run of the system on it has)"
        )
    return lines


def measure_beamwidth(run: Run, estimate: Run, sector: tuple[float, float], el: float) -> float:
    """The one-way 3-dB beamwidth (geometric mean of azimuth and elevation) of the system's
    antenna, its beam steered to the sector's middle. The antenna is measured through the
    :class:`~pasim_blocks.antennas.antenna.Antenna` contract (``build`` refuses another block)."""
    from ..antennas.beam_figures import build, measure_beams
    from .hardware import sector_middle

    block = build(estimate.graph(), run.source_antenna)
    (figures,) = measure_beams(block, [(sector_middle(sector), el)], seed=run.seed, span_deg=20.0)
    return float(math.sqrt(figures["beamwidth_az_deg"] * figures["beamwidth_el_deg"]))


def ensure_patterns(
    study: Study,
    runs: list[Run],
    out: Path,
    measuring: Measuring,
    pending: frozenset[str] = frozenset(),
) -> None:
    """Measure the antenna figures (:mod:`.patterns`) of every system, case and point whose
    first-seed estimate is finished, once: kept in the manifest under ``patterns``. Runs
    whose keys are ``pending`` count as not finished yet (runs in flight are taken in the
    study's order, whichever ends first)."""
    from pasim_graph.store import open_sweep

    cases = {c.name: c for c in study.cases}
    for run in runs:
        if not first_seed_estimate(study, run):
            continue
        if not measuring.wanted("patterns", point_key(run)):
            continue
        path = out / "runs" / run.key
        if run.key in pending or not finished(path):
            continue
        sweep, _ = open_sweep(path)
        start_patterns(measuring, run, cases[run.case], sweep["azimuth"].values)
    ensure_hardware(study, runs, out, measuring, pending)


def measure_ahead(
    study: Study, run: Run, runs: list[Run], executor: Any, measuring: Measuring
) -> None:
    """On a cluster, a first-seed estimate's antenna figures, and with its system's first
    such estimate the system's hardware, are measured as the run starts instead of once it
    has finished. The 10 m CPPAR's antenna (3.3 s, one task) was measured after its estimate,
    the fifteenth of the paper study's 19 runs, and ended after the last run on two workers
    (4 s of the study's tail). The figures are those measured from the finished store
    (:func:`estimate_azimuths` gives its beams' azimuths), of the same run a study one run
    at a time measures them from (:func:`ensure_patterns`, :func:`ensure_hardware`)."""
    if not first_seed_estimate(study, run):
        return
    case = next(c for c in study.cases if c.name == run.case)
    if measuring.wanted("patterns", point_key(run)):
        start_patterns(measuring, run, case, estimate_azimuths(executor))
    first = next(r for r in runs if r.system == run.system and first_seed_estimate(study, r))
    if first is run and measuring.wanted("hardware", run.system):
        start_hardware(measuring, run, case)


def first_seed_estimate(study: Study, run: Run) -> bool:
    """Whether ``run`` is an estimate of the study's first seed: what the antenna and
    hardware are measured from."""
    return run.kind == "estimate" and run.seed == study.seeds[0]


def point_key(run: Run) -> str:
    """``SYSTEM/CASE/POINT``: the manifest's key of a run's antenna figures and beamwidth."""
    return f"{run.system}/{run.case}/{run.point_name}"


def start_patterns(measuring: Measuring, run: Run, case: Case, azimuth: np.ndarray) -> None:
    """Measure the antenna figures of ``run``'s system, case and point at ``azimuth``, the
    beams of its store."""
    from .patterns import point_patterns

    key = point_key(run)
    args = (run.graph(), azimuth, case.elevation, run.seed)
    measuring.start("patterns", key, f"the antenna of {key}", point_patterns, *args)


def start_hardware(measuring: Measuring, run: Run, case: Case) -> None:
    """Measure ``run``'s system's hardware, steered to the middle of its case's sector."""
    from .hardware import sector_middle

    args = (run.case, run.point_name, run.graph(), sector_middle(case.sector), case.elevation)
    what = f"the hardware of {run.system}"
    measuring.start("hardware", run.system, what, hardware_record, *args, run.seed)


def estimate_azimuths(executor: Any) -> np.ndarray:
    """The azimuths of a run's first sweep's beams as its store will hold them (the beam
    source's, aligned to the truth), before the run: the executor's truth read and its
    once-per-run blocks run here (as the run does again)."""
    local = executor.local
    local.load()
    geometry = executor.sweeps[0].beam_geometry(local.run_static())
    return np.asarray(geometry["azimuth"].values, dtype=np.float64)


def ensure_hardware(
    study: Study,
    runs: list[Run],
    out: Path,
    measuring: Measuring,
    pending: frozenset[str] = frozenset(),
) -> None:
    """Measure each system's pattern, waveform and spectrum (:mod:`.hardware`) once, from its
    first finished estimate (the first case, unswept where it has such a point): kept in the
    manifest under ``hardware``."""
    cases = {c.name: c for c in study.cases}
    for run in sorted(runs, key=lambda r: r.point_name != "-"):
        if not first_seed_estimate(study, run):
            continue
        if not measuring.wanted("hardware", run.system):
            continue
        if run.key in pending or not finished(out / "runs" / run.key):
            continue
        start_hardware(measuring, run, cases[run.case])


def hardware_record(
    case: str, point: str, graph: Any, azimuth_deg: float, elevation_deg: float, seed: int
) -> dict[str, Any]:
    """A system's hardware as the manifest keeps it: where it was measured, and the parts."""
    from .hardware import system_hardware

    return {
        "case": case,
        "point": point,
        **system_hardware(graph, azimuth_deg, elevation_deg, seed),
    }


def beamwidth(study: Study, run: Run, runs: list[Run], state: dict[str, Any]) -> float | None:
    """The beamwidth a reference run's ideal antenna takes (None for other runs): measured
    once per system, case and point, and kept in the manifest."""
    if not run.antennas:
        return None
    bkey = point_key(run)
    bw = state["beamwidths"].get(bkey)
    if bw is None:
        estimate = next(
            r
            for r in runs
            if (r.system, r.case, r.point_name, r.kind)
            == (run.system, run.case, run.point_name, "estimate")
        )
        case = next(c for c in study.cases if c.name == run.case)
        bw = measure_beamwidth(run, estimate, case.sector, case.elevation)
        state["beamwidths"][bkey] = bw
    return float(bw)


def check_stores(study: Study, runs: list[Run], out: Path, state: dict[str, Any]) -> list[Run]:
    """The runs still to do. A store already in a run's place (finished or not) must say it
    is that run (:func:`.integrity.store_mismatch`): otherwise the study is refused, naming the
    store, which is left as it is."""
    from pasim_graph.dask_executor import DaskExecutor
    from pasim_graph.executor import RunOptions
    from pasim_graph.store import is_store, run_key, run_state

    from .integrity import store_mismatch

    todo = []
    for run in runs:
        path = out / "runs" / run.key
        stored = run_state(path) if path.exists() and is_store(path) else None
        if stored is not None:
            graph = run.graph(beamwidth(study, run, runs, state))
            # The key the executor would write: its options as it settles them.
            options = DaskExecutor(graph, RunOptions(seed=run.seed)).options
            why = store_mismatch(stored[0], run, run_key(graph, options))
            if why:
                raise StudyError(
                    f"{path}: refused, this store is not this run of the study: {why}; it is "
                    "left as it is: remove it for --resume to run it again, or use another --out"
                )
            if finished(path):  # every chunk, and every array its layout lists
                continue
        todo.append(run)
    return todo


def execute(
    study: Study,
    runs: list[Run],
    out: Path,
    state: dict[str, Any],
    *,
    workers: int | None,
    scheduler: str | None,
    progress: bool,
    after_run: Callable[[Run], None],
    log: Callable[[str], None] = lambda s: print(s, file=sys.stderr),
    at_once: int | None = None,
    client: Any = None,
) -> dict[str, Any]:
    """Run every store not yet finished; call ``after_run(run)`` as each one finishes (in the
    study's order, in this thread).

    On a cluster (``workers`` or ``scheduler``) several runs are in flight at once (at most
    ``at_once``, by default :func:`.inflight.runs_at_once`), recorded in the study's order
    (:func:`.inflight.in_order`); without one, one run after another in this thread.

    The study makes one client (and, with ``workers``, one LocalCluster), here in the calling
    thread, and every run uses it: no run makes, warms up or closes a client of its own. One
    client per run, made from the runs' threads at once, was seen to hang a study (8 runs
    laid out, none of them sending its inputs to the cluster, for 19 min). ``client``: one
    already connected to ``scheduler`` (the command's: to an external scheduler, whose
    shared storage it checked, or to the LocalCluster it keeps to draw the report on), used
    instead and left open. With a cluster, the antenna and hardware measurements are tasks on
    it too (:mod:`.measuring`).
    """
    from pasim_graph.cluster import LOCAL_SCHEDULERS, close, open_client, warm_up_workers
    from pasim_graph.dask_executor import DaskExecutor
    from pasim_graph.executor import RunOptions
    from pasim_graph.provenance import run_attrs
    from pasim_graph.resources import memory_available

    from .inflight import RUN_MEMORY, in_order, runs_at_once
    from .integrity import identity

    t_start = time.perf_counter()
    todo = check_stores(study, runs, out, state)
    given = client is not None
    cluster: Any = None
    warmed: set[type] = set()  # block classes the workers have been sent to warm up
    kept = len(runs) - len(todo)
    if kept:
        log(f"keeping {kept} finished run(s) of {len(runs)}")
    measuring = Measuring(state, lambda: save(out, state), log)
    ensure_patterns(study, runs, out, measuring)
    computed = 0
    pending = [r.key for r in todo]  # not yet recorded: the study's order

    def start(run: Run) -> Callable[[], float]:
        # In the calling thread, in the study's order: the graph (and the beamwidth it may
        # measure, kept in the manifest) is built here, never by two runs at once.
        path = out / "runs" / run.key
        path.parent.mkdir(parents=True, exist_ok=True)
        graph = run.graph(beamwidth(study, run, runs, state))
        attrs = {
            **run_attrs(
                graph.text(),
                str(study.system(run.system).graph),
                run.system,
                f"pasim study {study.file}",
            ),
            "study": study.file,
            **identity(run),
        }
        executor = DaskExecutor(
            graph, RunOptions(seed=run.seed), scheduler=scheduler, progress=progress, client=client
        )
        if client is not None:
            # Once per study for each block class: sent, not waited for (this thread builds
            # the next run meanwhile).
            new = [c for c in executor.worker_classes() if c not in warmed]
            if new:
                warm_up_workers(client, new, wait=False)
                warmed.update(new)
            measure_ahead(study, run, runs, executor, measuring)

        def one() -> float:
            t0 = time.perf_counter()
            executor.run(path, attrs, resume=path.exists(), command=f"pasim study {study.file}")
            return time.perf_counter() - t0

        return one

    def record(run: Run, dt: float) -> None:
        nonlocal computed
        computed += 1
        state["runs"][run.key] = {"seconds": round(dt, 2), "kind": run.kind}
        save(out, state)
        elapsed = time.perf_counter() - t_start
        left = elapsed / computed * (len(todo) - computed)
        log(f"[{kept + computed}/{len(runs)}] {run.key}: {dt:.1f} s; about {left:.0f} s left")
        measuring.gather()
        ensure_patterns(study, runs, out, measuring, frozenset(pending[computed:]))
        after_run(run)

    if todo and not given and (workers or scheduler not in (None, *LOCAL_SCHEDULERS)):
        client, cluster = open_client(workers, scheduler)
        if cluster is not None:
            scheduler = cluster.scheduler_address
    measuring.client = client
    # With a cluster this process only sets runs up beside the workers' chunks: OpenBLAS's
    # own threads here spun between its calls (3.3 s of CPU in the one-seed paper study on
    # two workers, on the cores the workers compute on). The set-ups' outputs and the
    # blocks they build are the same with one thread (the four paper systems' first chunk
    # to the bit, 2026-11-29); chunks always run with one (workers get it from their nanny).
    blas: Any = contextlib.nullcontext()
    if client is not None:
        from threadpoolctl import threadpool_limits

        blas = threadpool_limits(limits=1, user_api="blas")
    began, cpu = time.time(), time.process_time()
    try:
        with blas:
            limit = at_once if at_once is not None else runs_at_once(client)
            in_order(todo, start, record, limit, lambda: memory_available() >= RUN_MEMORY)
            measuring.gather(wait=True)
        # The study's record of this process while its runs ran (each invocation's): its
        # CPU in all its threads (the set-ups, the scheduler and client of a local cluster,
        # the runs' bookkeeping), the work more workers do not share (docs/scaling.md).
        if todo:
            state.setdefault(PROCESS, []).append(
                {
                    "start": round(began, 4),
                    "stop": round(time.time(), 4),
                    "cpu_s": round(time.process_time() - cpu, 4),
                    "workers": workers,
                }
            )
            save(out, state)
    finally:
        measuring.drop()
        close(client if not given else None, cluster)
    return {"computed": computed, "kept": kept, "seconds": time.perf_counter() - t_start}
