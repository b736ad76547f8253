"""``pasim study STUDY.yaml --out DIR``: every system x case x seed x sweep point, scored.

The study file is checked whole before any run (every problem named, exit 2); the runs go
into ``DIR/runs`` through the engine's executor, in this one process; ``scores.json`` and
``scores.csv`` are rewritten as runs finish. ``--resume`` completes a stopped study: finished
runs are kept, never recomputed.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

#: Seconds between two writings of scores.json while a study runs (it is always written at
#: the end, and when the study is stopped).
RESCORE_EVERY_S = 60.0


def _problems_class() -> type:
    from pasim_graph.graph import GraphError

    class StudyProblems(GraphError):
        """Every problem of a study file, reported together (exit 2)."""

        def report(self) -> str:
            n = len(self.problems)
            head = f"{n} problem{'s' if n != 1 else ''} in the study:"
            return "\n".join([head, *(f"  {p}" for p in self.problems)])

    return StudyProblems


class StudyCommand:
    help = "run a trade study (systems x cases x seeds x sweeps) and score it with a budget"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "study", metavar="STUDY.yaml", help="the study file (or, with --report-only, its DIR)"
        )
        parser.add_argument("--out", metavar="DIR", help="the study's folder (required to run)")
        parser.add_argument("--resume", action="store_true", help="complete a stopped study in DIR")
        where = parser.add_mutually_exclusive_group()
        where.add_argument("--workers", type=int, metavar="N", help="local worker processes")
        where.add_argument("--scheduler", metavar="ADDR", help="a dask.distributed scheduler")
        parser.add_argument("--progress", action="store_true", help="show each run's progress")
        parser.add_argument(
            "--check", action="store_true", help="validate the study and list its runs; run none"
        )
        parser.add_argument(
            "--yes",
            action="store_true",
            help="plan and run a study above the size limit (more than "
            "1000 runs or an estimated 24 h)",
        )
        report = parser.add_mutually_exclusive_group()
        report.add_argument(
            "--report-only",
            action="store_true",
            help="rebuild DIR/report.html from a study's folder (no run): pasim study DIR "
            "--report-only",
        )
        report.add_argument(
            "--no-report",
            action="store_true",
            help="write the scores only, no report.html (on a cluster, or to draw it later "
            "with --report-only: the figures take seconds per moment)",
        )

    def run(self, args: argparse.Namespace) -> int:
        if args.report_only:
            return self.report_only(args)
        from pasim_graph.cluster import StartingCluster, workers_in_range

        # The study's local cluster starts now, while the study is read, sized and planned
        # (0.3-0.5 s of its start and its workers' imports on the way, not before the first
        # run), when the command can run at all; a study refused after all closes it.
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
        early = None
        if args.out and not args.check and args.workers is not None:
            if workers_in_range(args.workers, cores):
                early = StartingCluster(args.workers)
        try:
            return self._run(args, cores, early)
        finally:
            if early is not None:
                early.drop()

    def _run(self, args: argparse.Namespace, cores: int | None, early: Any) -> int:
        from pasim_graph.cluster import (
            LOCAL_SCHEDULERS,
            SchedulerError,
            check_scheduler,
            check_storage,
            close,
            open_client,
            workers_in_range,
        )
        from pasim_graph.command_api import UserError
        from pasim_graph.dask_executor import ResourceError, ResumeError
        from pasim_graph.executor import BlockError
        from pasim_graph.steering import SteeringError

        StudyProblems = _problems_class()
        from pasim_graph.interrupt import StopMessage, Stopped, stop_on_signals
        from pasim_graph.store import NotAStoreError, StoreError, StoreExistsError

        from ..study.integrity import study_inputs
        from ..study.model import read_study
        from ..study.plan import plan_runs
        from ..study.reading import StoreReading
        from ..study.runner import StudyError, execute, take_folder, unscored
        from ..study.sizing import MAX_RUNS, MAX_SECONDS, duration, size_study
        from ..study.statistics import score_study, write_scores

        study = read_study(args.study)
        problems = list(study.problems)
        runs: list = []
        size = None
        if study.systems and study.cases and not problems:
            # Sized by arithmetic before the plan builds a graph per point.
            size = size_study(study)
            if size.over() and not args.yes:
                raise UserError(
                    f"{args.study}: {size.text()}: above the limit of {MAX_RUNS} runs or "
                    f"{duration(MAX_SECONDS)}; give --yes to plan and run it anyway"
                )
            print(f"{args.study}: {size.text()}", file=sys.stderr)
        if study.systems and study.cases:
            # The runs are planned even on a flawed file: every problem is named at once.
            runs, more = plan_runs(study)
            problems += more
        if problems:
            raise StudyProblems(problems)
        if args.check:
            about = f", about {duration(size.seconds)}" if size is not None else ""
            print(f"{args.study}: valid, {len(runs)} runs{about}")
            for r in runs:
                print(f"  {r.key}")
            return 0
        if not args.out:
            raise UserError("--out DIR is needed to run the study (or --check to validate it)")
        if args.workers is not None and not workers_in_range(args.workers, cores):
            raise UserError(f"--workers {args.workers}: give 1 to {cores or 'the cores'}")
        out = Path(args.out)
        client = None  # the study's one client to an external scheduler: closed here
        if args.scheduler:
            try:
                check_scheduler(args.scheduler)
                if args.scheduler not in LOCAL_SCHEDULERS:
                    try:
                        client, _ = open_client(None, args.scheduler)
                    except OSError as exc:  # distributed's TimeoutError is one
                        raise SchedulerError(
                            f"--scheduler {args.scheduler!r}: cannot connect ({exc})"
                        ) from None
                    # Before the study's folder is made: its workers must share it. The
                    # study then runs on the same client.
                    check_storage(args.scheduler, out, client)
            except SchedulerError as exc:
                close(client)
                raise UserError(str(exc)) from None
        try:
            state = take_folder(out, study, args.resume, study_inputs(study, runs))
        except StudyError as exc:
            close(client)
            raise UserError(str(exc)) from None

        latest: dict = {}
        read: dict = {}  # every store's errors, read once for all the rescores

        reading = StoreReading(read)

        def rescore() -> None:
            reading.collect()
            latest["scores"] = score_study(
                study, runs, out, state["beamwidths"], state.get("patterns", {}), read
            )
            write_scores(out, latest["scores"])
            latest["at"] = time.monotonic()

        def after_run(run: Any) -> None:
            # Each finished store's errors are read as the run is recorded (on the cluster,
            # while it computes the runs in flight), not all by the last scoring
            # (blocks/study/reading.py).
            reading.add(run.key, out / "runs" / run.key)
            # scores.json follows a long study along, at most once a minute: scoring every
            # finished run again after each one cost a small study more than its runs.
            if time.monotonic() - latest.get("at", started) >= RESCORE_EVERY_S:
                rescore()

        def warn_unscored() -> None:
            # A system none of whose cases was scored is named, not left out of the tables
            # silently. Stopped before any run finished here, the kept runs are scored.
            try:
                if "scores" not in latest:
                    rescore()
            except (StudyError, NotAStoreError):
                return  # a damaged kept store: the resume names it
            for line in unscored(study, runs, out, latest["scores"]):
                print(f"warning: {line}", file=sys.stderr)

        print(f"study {args.study}: {len(runs)} runs into {out}", file=sys.stderr)
        started = time.monotonic()
        cluster: Any = None
        report: dict | None = None
        try:
            with stop_on_signals():
                if args.workers and client is None:
                    # The study's cluster made here, not by execute, so that it outlives the
                    # runs: the stores are read and the report's figures drawn on it.
                    if early is not None:
                        client, cluster = early.take()
                    else:
                        client, cluster = open_client(args.workers, None)
                reading.client = client
                report = execute(
                    study,
                    runs,
                    out,
                    state,
                    workers=args.workers,
                    scheduler=cluster.scheduler_address if cluster is not None else args.scheduler,
                    progress=args.progress,
                    after_run=after_run,
                    client=client,
                )
        except Stopped as exc:
            reading.drop()  # the scoring below reads the stores itself
            warn_unscored()
            raise StopMessage(
                f"stopped by {exc}: finished runs are kept in {out}; complete the study with "
                "the same command and --resume",
                exc.exit_code,
            ) from None
        except (BlockError, SteeringError) as exc:
            raise UserError(f"{args.study}: {exc}") from None
        except StudyError as exc:
            raise UserError(str(exc)) from None
        except (
            StoreError,
            StoreExistsError,
            NotAStoreError,
            ResumeError,
            ResourceError,
            SchedulerError,
        ) as exc:
            raise UserError(str(exc)) from None
        finally:
            if report is None:
                close(client, cluster)
        try:
            self._finish(args, out, report, rescore, warn_unscored, client)
        finally:
            close(client, cluster)
        return 0

    def _finish(
        self,
        args: argparse.Namespace,
        out: Path,
        report: dict,
        rescore: Any,
        warn_unscored: Any,
        client: Any,
    ) -> None:
        """The study's last scores, its summary line and its report (drawn on ``client``'s
        cluster when there is one)."""
        from pasim_graph.command_api import UserError
        from pasim_graph.store import NotAStoreError

        from ..study.runner import StudyError

        try:
            rescore()
        except (StudyError, NotAStoreError) as exc:
            # A run's store damaged on disk since it was kept: named, one line.
            raise UserError(str(exc)) from None
        warn_unscored()
        print(
            f"wrote {out / 'scores.json'} and scores.csv: {report['computed']} runs computed, "
            f"{report['kept']} kept, {report['seconds']:.1f} s",
            file=sys.stderr,
        )
        if args.no_report:
            print(
                f"no report (--no-report): pasim study {out} --report-only draws it",
                file=sys.stderr,
            )
            return
        from pasim_graph.interrupt import StopMessage, Stopped, stop_on_signals

        from ..study.figures import Drawing
        from ..study.report import write_report

        t0, drawing = time.perf_counter(), Drawing(client)
        try:
            # Stopped while the figures are drawn: the runs and scores are all kept, only the
            # report is missing (report.html is written whole or not at all).
            with stop_on_signals():
                path = write_report(out, drawing)
        except Stopped as exc:
            raise StopMessage(
                f"stopped by {exc} while drawing the report: the runs and scores are kept in "
                f"{out}; `pasim study {out} --report-only` draws it",
                exc.exit_code,
            ) from None
        where = " on the cluster" if client is not None else ""
        print(
            f"wrote {path} in {time.perf_counter() - t0:.1f} s ({drawing.count} figures, "
            f"{drawing.seconds:.1f} s of drawing{where})",
            file=sys.stderr,
        )

    def report_only(self, args: argparse.Namespace) -> int:
        from pasim_graph.command_api import UserError

        from ..study.report import write_report
        from ..study.runner import StudyError

        folder = Path(args.out or args.study)
        if not folder.is_dir():
            raise UserError(
                f"{folder}: not a folder; --report-only takes a study's folder "
                "(pasim study DIR --report-only)"
            )
        try:
            path = write_report(folder)
        except StudyError as exc:
            raise UserError(str(exc)) from None
        print(f"wrote {path}", file=sys.stderr)
        return 0


COMMAND = StudyCommand()
