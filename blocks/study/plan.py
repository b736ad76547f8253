"""Every run a study needs, each graph validated by the engine before any run starts.

For every system, case and sweep point: one ``estimate`` run per seed (the system as built)
and the three noise-free references the error budget needs, all with the weather channel's
``method: expected`` (the beam- and range-smoothed truth, no noise):

- ``expected`` (one per seed: an impaired array is drawn from the seed): the system itself;
- ``sidelobe_free``: the antenna replaced by ``antenna.ideal``, a Gaussian main lobe of the
  system's own 3-dB beamwidth (measured from its pattern at the sector's middle beam);
- ``short_pulse``: that and every waveform replaced by a short rectangular pulse
  (:data:`SHORT_PULSE_S`), so that the range response is close to an impulse.

A system whose antenna offers a choice of ``calibration`` (per-beam or boresight radar
constant) is also run, at its unswept point and first seed, as an estimate under each other
choice (``calibration_CHOICE``): the per-azimuth ZDR bias of the paper's figures 9e-11e under
both calibrations.

Reference runs score every gate with a truth (scorer and processor SNR thresholds at their
floors), so that the estimate's scored gates all have a reference value.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pasim_graph.graph import Graph, GraphError, resolve
from pasim_graph.graphfile import BlockSpec, GraphSpec, Problem, read
from pasim_graph.store import input_paths

from .model import Case, Study, System, point_name

SHORT_PULSE_S = 2e-7  # 30 m of range resolution: far below the 250 m truth gates
SHORT_PULSE_RATE_HZ = 5e7
PLACEHOLDER_BEAMWIDTH_DEG = 1.0
KINDS = ("estimate", "expected", "sidelobe_free", "short_pulse")
CALIBRATION = "calibration_"  # the kind of a run under another calibration: calibration_CHOICE


@dataclass
class Run:
    system: str
    case: str
    point: dict[str, Any]
    kind: str
    seed: int
    spec: GraphSpec
    overrides: dict[str, Any]
    antennas: list[str] = field(default_factory=list)  # ideal antennas to give a beamwidth
    source_antenna: str = ""  # the system's antenna whose beamwidth they take
    inputs: dict[str, str] = field(default_factory=dict)  # files it reads: {BLOCK.PARAM: path}

    @property
    def point_name(self) -> str:
        return point_name(self.point)

    @property
    def key(self) -> str:
        """The run's folder under the study's ``runs/``."""
        seeded = self.kind in ("estimate", "expected") or self.kind.startswith(CALIBRATION)
        seed = f"seed{self.seed}" if seeded else "ref"
        return f"{self.system}/{self.case}/{self.point_name}/{self.kind}-{seed}.zarr"

    def graph(self, beamwidth_deg: float | None = None) -> Graph:
        overrides = dict(self.overrides)
        bw = beamwidth_deg or PLACEHOLDER_BEAMWIDTH_DEG
        support = min(45.0, max(2.0, 2.5 * bw))
        for name in self.antennas:
            overrides[f"{name}.beamwidth_deg"] = bw
            # The Gaussian is cut at support_deg: 2.5 beamwidths is -75 dB one-way.
            overrides[f"{name}.support_deg"] = support
        graph = resolve(self.spec, overrides).graph
        if not self.antennas:
            return graph
        # A wide stand-in beam (a 2 m array's 5 deg) reaches past the truth's default
        # margin: the truth is read that much wider.
        wider = {
            f"{name}.margin_deg": support + 1.0
            for name in graph.by_role("truth")
            if "margin_deg" in graph.classes[name].params
            and float(graph.value(name, "margin_deg")) < support + 1.0
        }
        return resolve(self.spec, overrides | wider).graph if wider else graph


def _with_params(graph: Graph, test: Any, value: Any) -> dict[str, Any]:
    return {
        f"{name}.{p}": value for name, cls in graph.classes.items() for p in cls.params if test(p)
    }


def case_overrides(graph: Graph, case: Case) -> tuple[dict[str, Any], list[str]]:
    """The overrides that put a system's graph on a case, and what stops it."""
    out: dict[str, Any] = {}
    problems: list[str] = []
    truth, scan = graph.by_role("truth"), graph.by_role("scan")
    if len(scan) != 1:
        return out, [f"needs exactly one scan block, found {len(scan)}"]
    s = scan[0]
    out |= {
        f"{s}.azimuth_start_deg": case.sector[0],
        f"{s}.azimuth_stop_deg": case.sector[1],
        f"{s}.elevation_deg": case.elevation,
    }
    if len(truth) == 1:
        t = truth[0]
        params = graph.classes[t].params
        if "path" in params:
            out[f"{t}.path"] = case.truth
        if "elevation_deg" in params:
            out[f"{t}.elevation_deg"] = case.elevation
        if "azimuth_start_deg" in params and "azimuth_stop_deg" in params:
            out[f"{t}.azimuth_start_deg"] = case.sector[0]
            out[f"{t}.azimuth_stop_deg"] = case.sector[1]
        if case.fields:
            if "fields" in params:
                out[f"{t}.fields"] = dict(case.fields)
            else:
                problems.append(
                    f"truth block '{t}' ({graph.classes[t].type_name}) has no 'fields' "
                    "parameter for the case's fields"
                )
        if case.sweeps != "single":
            if "sweeps" in params and case.sweeps in (params["sweeps"].choices or ()):
                out[f"{t}.sweeps"] = case.sweeps
                out[f"{t}.elevation_interpolation"] = case.interpolation
            else:
                problems.append(
                    f"truth block '{t}' ({graph.classes[t].type_name}) cannot read the case's "
                    f"truth as a {case.sweeps} (no such choice of its 'sweeps' parameter)"
                )
    elif case.truth or case.sweeps != "single":
        what = "file" if case.truth else f"as a {case.sweeps}"
        problems.append(f"has {len(truth)} truth blocks: cannot read the case's truth {what}")
    return out, problems


def _case_key(case: Case, key: str) -> str:
    """The case's own setting behind one of its overrides (``key``, BLOCK.PARAM)."""
    param = key.partition(".")[2]
    if param.startswith("azimuth_"):
        return f"sector {case.sector[0]:g}:{case.sector[1]:g}"
    if param == "elevation_deg":
        return f"elevation {case.elevation:g}"
    if param == "path":
        return f"truth {case.truth or '(the bundled scene)'}"
    if param == "elevation_interpolation":
        return f"interpolation {case.interpolation}"
    if param == "fields":
        return f"fields {case.fields}"
    return f"{param} {case.sweeps}"


def collisions(study: Study, system: System, case: Case, on_case: dict[str, Any]) -> list[Problem]:
    """A system's ``set:`` or sweep of a parameter that the case sets itself (the scan's
    sector and elevation, the truth's file, cut and sweeps): refused, never silently
    overridden by the case. A study varies these by its cases, one case per setting."""
    sweep = next((s for s in study.sweeps if system.name in s.systems), None)
    out = []
    for key in on_case:
        given = []
        if key in system.overrides:
            given.append((system.override_lines.get(key, system.line), f"set {key}"))
        if sweep is not None and key in sweep.values:
            given.append((sweep.value_lines.get(key, sweep.line), f"sweep {key}"))
        for line, what in given:
            out.append(
                Problem(
                    study.file,
                    line,
                    "",
                    f"system '{system.name}', {what}",
                    f"collides with case '{case.name}' ({_case_key(case, key)}), which sets "
                    f"{key} itself; vary it with one case per value instead",
                )
            )
    return out


def expected_overrides(graph: Graph) -> dict[str, Any]:
    """Every block that declares an expected level, set to it (``Block.expected_level``)."""
    return {
        f"{name}.{cls.fidelity_param}": cls.expected_level
        for name, cls in graph.classes.items()
        if cls.fidelity_param and cls.expected_level
    }


def calibration_choices(graph: Graph) -> tuple[str, dict[str, dict[str, Any]]]:
    """The calibration a graph's antennas use, and the overrides for each other choice."""
    names = [
        n
        for n in _kinds_of(graph, "pattern", "outputs")
        if (q := graph.classes[n].params.get("calibration")) is not None and q.choices
    ]
    if not names:
        return "", {}
    own = str(graph.value(names[0], "calibration"))
    choices = graph.classes[names[0]].params["calibration"].choices or ()
    return own, {str(c): {f"{n}.calibration": c for n in names} for c in choices if str(c) != own}


def _floors(graph: Graph) -> dict[str, Any]:
    def floor(p: str) -> bool:
        return p == "min_snr_db" or (p.startswith("snr_threshold_") and p.endswith("_db"))

    return _with_params(graph, floor, -100.0)


def _kinds_of(graph: Graph, kind: str, side: str) -> list[str]:
    return sorted(
        n
        for n, c in graph.classes.items()
        if any(p.type.kind == kind for p in getattr(c, side).values())
    )


def _variant(spec: GraphSpec, graph: Graph, short: bool) -> tuple[GraphSpec, list[str], str]:
    """The spec with the antenna made ideal (and the pulse short), the ideal antennas, and
    the system antenna they stand for."""
    spec = copy.deepcopy(spec)
    antennas = _kinds_of(graph, "pattern", "outputs")
    for name in antennas:
        line = spec.blocks[name].line
        spec.blocks[name] = BlockSpec("antenna.ideal", {}, line)
    if short:
        pulse_in = set(_kinds_of(graph, "pulse", "inputs"))
        for name in _kinds_of(graph, "pulse", "outputs"):
            if name in pulse_in:
                continue  # an amplifier: kept, it passes the short pulse on
            params = {"width_s": SHORT_PULSE_S, "sample_rate_hz": SHORT_PULSE_RATE_HZ}
            spec.blocks[name] = BlockSpec("waveform.rectangular", params, spec.blocks[name].line)
    return spec, antennas, antennas[0] if antennas else ""


def plan_runs(study: Study) -> tuple[list[Run], list[Problem]]:
    """Every run of ``study``, each graph validated; problems collected, never raised.

    Each point's estimate graph is validated by the engine; the other runs of a system and
    case differ from it by what the first point settles (the case, the reference levels, the
    stand-in antenna and pulse), so their graphs are validated at the first point only, and
    a point's files are its estimate's. One resolve per point: a 30 x 30 sweep plans in
    seconds, not minutes (:mod:`.sizing` counts a study without planning it)."""
    runs: list[Run] = []
    problems: list[Problem] = []
    f = study.file
    for system in study.systems:
        spec = read(system.graph)
        if spec.problems and not spec.blocks_read:
            for p in spec.problems:
                problems.append(
                    Problem(f, system.line, "", f"system '{system.name}'", f"graph {p}")
                )
            continue
        for case in study.cases:
            memo: dict[str, Any] = {}
            for point in study.points(system.name):
                runs += _system_runs(study, system, spec, case, point, problems, memo)
    problems += _truth_problems(study)
    return runs, problems


def _located(study: Study, system: System, point: dict[str, Any], p: Problem) -> Problem:
    """An engine problem of a study's override, at the study line that set it."""
    sweep = next((s for s in study.sweeps if system.name in s.systems), None)
    for key in point:
        b, _, param = key.partition(".")
        if p.block == b and (f"'{param}'" in p.item or key in p.item):
            line = sweep.value_lines.get(key, sweep.line) if sweep else system.line
            return Problem(study.file, line, "", f"system '{system.name}', sweep {key}", str(p))
    for key, line in system.override_lines.items():
        b, _, param = key.partition(".")
        if p.block == b and (f"'{param}'" in p.item or key in p.item):
            return Problem(study.file, line, "", f"system '{system.name}', set {key}", str(p))
    return Problem(study.file, system.line, "", f"system '{system.name}'", str(p))


def _settle(
    study: Study,
    system: System,
    spec: GraphSpec,
    case: Case,
    point: dict[str, Any],
    problems: list[Problem],
) -> dict[str, Any]:
    """What every point of a system on a case shares (from its first point's graph): the
    case's overrides, the reference levels, the calibration choices, the stand-in variants.
    Empty where the graph cannot be built (its problems are named)."""
    try:
        graph = resolve(spec, {**system.overrides, **point}).graph
    except GraphError as exc:
        problems += [_located(study, system, point, p) for p in exc.problems]
        return {}
    on_case, trouble = case_overrides(graph, case)
    where = f"system '{system.name}', case '{case.name}'"
    problems += [Problem(study.file, case.line, "", where, t) for t in trouble]
    problems += collisions(study, system, case, on_case)
    method = expected_overrides(graph)
    if not method:
        problems.append(
            Problem(study.file, system.line, "", where, "no weather block with method 'expected'")
        )
    variants = []
    for kind, short in (("sidelobe_free", False), ("short_pulse", True)):
        vspec, antennas, source = _variant(spec, graph, short)
        if not antennas:
            problems.append(Problem(study.file, system.line, "", where, "no antenna block"))
            continue
        # Overrides of the replaced blocks do not apply to their stand-ins.
        replaced = set(antennas) | {n for n, b in vspec.blocks.items() if b != spec.blocks.get(n)}
        variants.append((kind, vspec, antennas, source, replaced))
    return {
        "on_case": on_case,
        "reference": method | _floors(graph),
        "calibration": calibration_choices(graph)[1],
        "variants": variants,
    }


def _system_runs(
    study: Study,
    system: System,
    spec: GraphSpec,
    case: Case,
    point: dict[str, Any],
    problems: list[Problem],
    memo: dict[str, Any],
) -> list[Run]:
    first = not memo
    if first:
        memo.update(_settle(study, system, spec, case, point, problems))
        if not memo:
            return []
    where = f"system '{system.name}', case '{case.name}'"
    overrides = {**system.overrides, **point, **memo["on_case"]}
    reference = overrides | memo["reference"]
    runs = [Run(system.name, case.name, point, "estimate", s, spec, overrides) for s in study.seeds]
    runs += [
        Run(system.name, case.name, point, "expected", s, spec, reference) for s in study.seeds
    ]
    if not point:
        for choice, more in memo["calibration"].items():
            kind = f"{CALIBRATION}{choice}"
            runs.append(
                Run(system.name, case.name, point, kind, study.seeds[0], spec, overrides | more)
            )
    for kind, vspec, antennas, source, replaced in memo["variants"]:
        kept = {k: v for k, v in reference.items() if k.partition(".")[0] not in replaced}
        runs.append(
            Run(system.name, case.name, point, kind, study.seeds[0], vspec, kept, antennas, source)
        )
    if not first:
        # The estimate's graph at this point, validated; the other runs' are the first
        # point's with this point's values.
        try:
            files = input_paths(runs[0].graph())
        except GraphError as exc:
            problems += [_located(study, system, point, p) for p in exc.problems]
            return []
        for run in runs:
            run.inputs = dict(files)
        return runs
    checked: dict[str, dict[str, str]] = {}  # the seeds of a kind share one graph
    # A problem the runs of several kinds share (a sector behind a planar face) is named
    # once, with its kinds.
    found: dict[str, list[str]] = {}
    for run in runs:
        if run.kind in checked:
            run.inputs = dict(checked[run.kind])
            continue
        try:
            run.inputs = checked[run.kind] = input_paths(run.graph())
        except GraphError as exc:
            checked[run.kind] = {}
            for p in exc.problems:
                found.setdefault(str(p), []).append(run.kind)
    for text, kinds in found.items():
        runs_of = f"{kinds[0]} run" if len(kinds) == 1 else f"{', '.join(kinds)} runs"
        problems.append(Problem(study.file, case.line, "", f"{where}, {runs_of}", text))
    return runs


def _truth_problems(study: Study) -> list[Problem]:
    """A case's sector or elevation that its truth file does not cover."""
    from .. import DEFAULT_SCENE
    from ..truth.nexrad_io import read_truth_sweep
    from ..truth.radar_files import is_level2, read_radar_sweep

    out = []
    for case in study.cases:
        path = case.truth or DEFAULT_SCENE
        if case.truth and not Path(case.truth).is_file():
            continue  # reported by the model
        try:
            # the truth block's own choice of reader: Level-II, or xradar for other formats
            if is_level2(path):
                if case.fields:
                    raise ValueError(
                        f"{path}: a NEXRAD Level-II volume names its moments itself; the "
                        "case's 'fields' applies to files in other formats"
                    )
                sweep = read_truth_sweep(path, case.elevation)
            else:
                sweep = read_radar_sweep(path, case.elevation, fields=case.fields or None)
        except Exception as exc:  # a broken file: named, with its reason
            out.append(Problem(study.file, case.line, "", f"case '{case.name}'", f"truth: {exc}"))
            continue
        where = f"case '{case.name}'"
        if abs(sweep.elevation_deg - case.elevation) > 1.0:
            out.append(
                Problem(
                    study.file,
                    case.line,
                    "",
                    where,
                    f"elevation {case.elevation:g} deg: the nearest cut of the truth is at "
                    f"{sweep.elevation_deg:.2f} deg",
                )
            )
        gap = largest_gap(sweep.azimuth_deg, case.sector)
        if gap > 3 * sweep.radial_width_deg:
            out.append(
                Problem(
                    study.file,
                    case.line,
                    "",
                    where,
                    f"sector {case.sector[0]:g}:{case.sector[1]:g} lies outside the truth: "
                    f"{gap:.1f} deg of it without a truth radial",
                )
            )
    return out


def largest_gap(azimuth: Any, sector: tuple[float, float]) -> float:
    """The longest stretch of ``sector`` (deg) without a radial of ``azimuth``."""
    import numpy as np

    start, stop = sector
    span = (stop - start) % 360.0 or 360.0
    rel = np.sort((np.asarray(azimuth) - start) % 360.0)
    rel = rel[rel <= span]
    if rel.size == 0:
        return span
    edges = np.concatenate([[0.0], rel, [span]])
    return float(np.max(np.diff(edges))) if math.isfinite(span) else span
