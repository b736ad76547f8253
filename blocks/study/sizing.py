"""A study's size before any work: how many runs, and about how long they take.

Counted by arithmetic from the study file (systems x cases x sweep points x runs per point),
never by building the runs: :func:`.plan.plan_runs` resolves a graph per point, which a
300 x 300 sweep cannot afford before saying how big it is. One graph per system and case
(its first point) gives the beams (from its beam source alone, no other block built: an
array antenna's set-up takes up to a second), the pulses (a swept pulse count at its mean),
the fidelity level and the calibration choices.

The time: each run costs :data:`PER_RUN_S` plus its beams x :data:`PER_BEAM_S` of its
fidelity level (the weather channel's ``method``: the estimate runs at the graph's, the
expected and reference runs at ``expected``) x pulses / 64. Measured by
``benchmarks/study_cost.py`` (the generic radar, 64 pulses, H and V, the bundled scene, as a
study runs a run) on the 2-core AMD EPYC, in CPU seconds of the run's process: the machine
was shared at a load of 13-16, and wall time there was 3 to 10 times the CPU time. An array antenna
costs about twice the pencil beam's per beam (``docs/performance.md``), so the estimate is a
lower bound for arrays. Not counted: the pattern and hardware measurements (about a second
per point) and the report.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .model import Study

#: CPU seconds per beam of a whole run at 64 pulses, per fidelity level (study_cost.py,
#: 2026-11-28: benchmarks/results/study_cost_2026-11-28.jsonl). monte_carlo is not measured
#: here: 41 x covariance (docs/tradeoff.md).
PER_BEAM_S = {"expected": 0.041, "combined": 0.072, "covariance": 0.150}
PER_BEAM_S["monte_carlo"] = 41 * PER_BEAM_S["covariance"]
#: Seconds of every run whatever its beams: graph, truth read, the store's layout and close.
PER_RUN_S = 1.4
REFERENCE_PULSES = 64
#: A study above either limit is refused without ``--yes``.
MAX_RUNS = 1000
MAX_SECONDS = 24 * 3600.0


@dataclass
class Size:
    runs: int = 0
    seconds: float = 0.0
    unknown: list[str] = field(default_factory=list)  # systems whose graph could not be built

    def over(self) -> bool:
        return self.runs > MAX_RUNS or self.seconds > MAX_SECONDS

    def text(self) -> str:
        more = " at least" if self.unknown else ""
        return (
            f"{self.runs} runs, about{more} {duration(self.seconds)} of computing at the "
            "measured costs per beam (docs/study.md)"
        )


def duration(seconds: float) -> str:
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    if seconds < 2 * 86400:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.0f} days"


def run_seconds(beams: int, method: str, pulses: float) -> float:
    per_beam = PER_BEAM_S.get(method, PER_BEAM_S["covariance"])
    scale = 1.0 if method == "expected" else pulses / REFERENCE_PULSES
    return PER_RUN_S + beams * per_beam * scale


def size_study(study: Study) -> Size:
    """How many runs ``study`` makes and about how long they take (see the module)."""
    from pasim_graph.graph import resolve
    from pasim_graph.graphfile import read

    from .plan import calibration_choices, case_overrides

    size = Size()
    seeds = len(study.seeds)
    for system in study.systems:
        points = study.point_count(system.name)
        first = study.first_point(system.name)
        sweep = next((s for s in study.sweeps if system.name in s.systems), None)
        sweep_values = sweep.values if sweep is not None else {}
        spec = read(system.graph)
        for case in study.cases:
            try:
                graph = resolve(spec, {**system.overrides, **first}).graph
                on_case, _ = case_overrides(graph, case)
                graph = resolve(spec, {**system.overrides, **first, **on_case}).graph
            except Exception:  # a graph that cannot be built: named by the plan's checks
                size.runs += points * (2 * seeds + 2)
                size.unknown.append(system.name)
                continue
            calibrations = 0 if first else len(calibration_choices(graph)[1])
            beams, method, pulses = _cost_of(graph)
            # The cost is linear in the pulses: a swept pulse count at its mean is exact.
            swept = [v for k, v in sweep_values.items() if k.endswith(".pulses")]
            if swept and all(isinstance(x, int) for x in swept[0]):
                pulses = sum(swept[0]) / len(swept[0])
            estimate = run_seconds(beams, method, pulses)
            reference = run_seconds(beams, "expected", pulses)
            size.runs += points * (2 * seeds + 2) + calibrations
            size.seconds += points * (seeds * (estimate + reference) + 2 * reference)
            size.seconds += calibrations * estimate
    return size


def _cost_of(graph: Any) -> tuple[int, str, int]:
    """The beams of a graph's scan (every sweep), its weather method and pulses per dwell."""
    from pasim_graph.sweeps import sweep_beam_counts

    beams = sum(sweep_beam_counts(graph))
    method, pulses = "covariance", REFERENCE_PULSES
    for name, cls in graph.classes.items():
        if cls.fidelity_param and cls.expected_level:
            method = str(graph.value(name, cls.fidelity_param))
    for name in graph.by_role("scan"):
        if "pulses" in graph.classes[name].params:
            pulses = int(graph.value(name, "pulses"))
    return beams, method, pulses
