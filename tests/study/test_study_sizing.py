"""Studies sized before work: the run count by arithmetic and a time estimate, printed by
``--check`` and before any run; a study above the limit refused without ``--yes``; planning
that resolves one graph per sweep point, not one per run."""

from __future__ import annotations

import shutil
import time
from pathlib import Path

import pytest
from pasim_blocks.study import plan, sizing
from pasim_blocks.study.model import read_study

from ..conftest import GRAPHS, pasim, pasim_out

FIX = Path(__file__).parents[1] / "fixtures" / "study"

STUDY = """format: pasim-study/1
systems:
  - {name: narrow, graph: small_pencil.yaml}
  - {name: planar, graph: small_planar.yaml}
  - {name: bits, graph: small_planar.yaml}
cases:
  - {name: convective, truth: "", sector: "264:288", elevation: 0.5}
  - {name: other, truth: "", sector: "246:258", elevation: 0.5}
seeds: [0, 3]
sweeps:
  - {systems: [bits], values: {antenna.phase_bits: [2, 3], scan.pulses: [8, 16]}}
  - {systems: [narrow], values: {antenna.first_sidelobe_db: [-20, -25]}}
"""


def write(folder: Path, text: str) -> Path:
    for g in ("small_pencil.yaml", "small_planar.yaml", "small_wide.yaml"):
        shutil.copy(FIX / g, folder / g)
    path = folder / "study.yaml"
    path.write_text(text)
    return path


def huge(folder: Path, n: int, seeds: int) -> Path:
    sidelobes = ", ".join(f"{-20 - 0.1 * i:.1f}" for i in range(n))
    pulses = ", ".join(str(8 + i) for i in range(n))
    return write(
        folder,
        "format: pasim-study/1\n"
        "systems:\n  - {name: narrow, graph: small_pencil.yaml}\n"
        'cases:\n  - {name: convective, truth: "", sector: "280:282", elevation: 0.5}\n'
        f"seeds: {list(range(seeds))}\n"
        "sweeps:\n  - systems: [narrow]\n"
        f"    values: {{antenna.first_sidelobe_db: [{sidelobes}], scan.pulses: [{pulses}]}}\n",
    )


def test_the_counted_runs_are_the_planned_runs(tmp_path):
    # Sweeps of two parameters and of one, an unswept array with a calibration choice (its
    # calibration run), two seeds, two cases: the arithmetic gives the plan's number.
    study = read_study(write(tmp_path, STUDY))
    runs, problems = plan.plan_runs(study)
    assert not problems, problems
    assert any(r.kind.startswith(plan.CALIBRATION) for r in runs)
    size = sizing.size_study(study)
    assert size.runs == len(runs)
    assert not size.unknown
    # The estimate is each planned run's cost, at its graph's beams, pulses and level.
    want = 0.0
    for run in runs:
        beams, method, pulses = sizing._cost_of(run.graph())
        want += sizing.run_seconds(beams, method, pulses)
    assert size.seconds == pytest.approx(want)


def test_a_huge_study_is_answered_without_planning(tmp_path, capsys, monkeypatch):
    """300 x 300 sweep points x 10 seeds: the count and estimate, refused above the limit,
    without building a single run's graph (the plan would resolve 90,000 graphs)."""
    sizing.size_study(read_study(huge(tmp_path, 2, 1)))  # imports paid before the clock

    def planned(*args, **kwargs):
        raise AssertionError("the study was planned run by run to be counted")

    monkeypatch.setattr(plan, "plan_runs", planned)
    path = huge(tmp_path, 300, 10)
    cpu, wall = time.process_time(), time.perf_counter()
    code, err = pasim(capsys, "study", str(path), "--check")
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    assert code == 2, err
    (line,) = err.strip().splitlines()
    n = 300 * 300 * (2 * 10 + 2)  # points x (estimate and expected per seed + 2 references)
    assert line.startswith(f"error: {path}: {n} runs, about "), line
    assert "--yes" in line and str(sizing.MAX_RUNS) in line
    # The bound: answered within 5 s. CPU time of this process, so that the other
    # work sharing the machine does not decide it; the wall time is only reported.
    assert cpu < 5.0, f"{cpu:.1f} s of CPU ({wall:.1f} s wall) to size the study"


def test_yes_plans_a_study_above_the_limit(tmp_path, capsys, monkeypatch):
    path = write(tmp_path, STUDY.split("sweeps:")[0].replace("264:288", "280:288"))
    monkeypatch.setattr(sizing, "MAX_RUNS", 3)
    code, out, err = pasim_out(capsys, "study", str(path), "--check")
    assert code == 2 and "Traceback" not in err
    runs = len(plan.plan_runs(read_study(path))[0])
    assert f"{runs} runs, about" in err and "above the limit of 3 runs" in err, err
    code, out, err = pasim_out(capsys, "study", str(path), "--check", "--yes")
    assert code == 0, err
    assert f"{runs} runs, about" in err  # printed before the plan
    assert f"valid, {runs} runs, about" in out


def test_planning_resolves_one_graph_per_sweep_point(tmp_path, monkeypatch):
    """Where the planning time went: every run's graph (7 per point with one seed) was
    resolved, each a deep copy of the spec and a validation. Now each point's estimate is,
    and the other runs at the first point only."""
    study = read_study(huge(tmp_path, 4, 1))
    calls = []
    real = plan.resolve

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(plan, "resolve", counted)
    runs, problems = plan.plan_runs(study)
    assert not problems, problems
    points = 4 * 4
    assert len(runs) == points * 4
    assert len(calls) <= points + 8, f"{len(calls)} graphs resolved for {points} points"


@pytest.mark.parametrize(
    "name",
    ["generic_radar", "generic_vcp212", "atd_schedule", "generic_split_cut", "generic_rhi"],
)
def test_beams_are_counted_from_the_beam_source_alone(name):
    """The sizing counts each sweep's beams without building the graph's other blocks (an
    antenna's set-up took 1.5 s of the paper study's start): the same counts as the
    executors that run the graph (one or several sweeps, a schedule, an RHI)."""
    from pasim_graph import load
    from pasim_graph.executor import RunOptions
    from pasim_graph.sweeps import sweep_beam_counts, sweep_executors

    graph = load(GRAPHS / f"{name}.yaml")
    want = [s.plan.beam_count for s in sweep_executors(graph, RunOptions())]
    assert sweep_beam_counts(graph) == want
