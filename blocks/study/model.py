"""The study file (``format: pasim-study/1``): systems x cases x seeds x sweep points.

```yaml
format: pasim-study/1
title: Paper Tables 7-8          # optional
reference: generic               # optional: the system whose expected level is the reference
systems:
  - {name: generic, graph: generic_radar.yaml}
  - {name: cppar10, graph: cppar10_radar.yaml, set: {scan.pulses: 64}}
cases:
  - {name: convective, truth: "", sector: "240:330", elevation: 0.5}
  - {name: storm-3d, truth: "", sector: "240:330", elevation: 0.5, sweeps: volume}
  - {name: mobile, truth: mobile.nc, sector: "0:90", elevation: 1.0, fields: {DBZH: ZH_QC}}
seeds: [0]
sweeps:                          # optional
  - {systems: [cppar10], values: {antenna.phase_bits: [3, 4, 5]}}
```

Graph and truth paths are relative to the study file. Reading never raises on bad content:
every problem is collected with its line, as graph files are (:mod:`pasim_graph.graphfile`).
"""

from __future__ import annotations

import itertools
import math
import os
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from pasim_graph.graphfile import MAX_GRAPH_BYTES, Loader, Problem, structure_problems

FORMAT = "pasim-study/1"
NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]{0,63}$")
TOP_KEYS = ("format", "title", "reference", "systems", "cases", "seeds", "sweeps")


@dataclass
class System:
    name: str
    graph: Path
    overrides: dict[str, Any] = field(default_factory=dict)
    line: int = 0
    override_lines: dict[str, int] = field(default_factory=dict)


@dataclass
class Case:
    name: str
    truth: str  # "" = the bundled scene
    sector: tuple[float, float]
    elevation: float
    line: int = 0
    sweeps: str = "single"  # "volume": every sweep of the truth, weighted over elevation
    interpolation: str = "nearest"  # between a volume's sweeps
    fields: dict[str, str] = field(default_factory=dict)  # moment -> the truth file's field


CASE_SWEEPS = ("single", "volume")
CASE_INTERPOLATIONS = ("nearest", "linear")


@dataclass
class Sweep:
    systems: list[str]
    values: dict[str, list[Any]]
    line: int = 0
    value_lines: dict[str, int] = field(default_factory=dict)

    def count(self) -> int:
        """How many points, without listing them."""
        return math.prod(len(v) for v in self.values.values())

    def points(self) -> list[dict[str, Any]]:
        keys = list(self.values)
        return [
            dict(zip(keys, combo, strict=True))
            for combo in itertools.product(*(self.values[k] for k in keys))
        ]


def point_name(point: dict[str, Any]) -> str:
    """``"-"`` for no sweep, else ``PARAM=VALUE[,PARAM=VALUE]``."""
    return ",".join(f"{k}={v}" for k, v in point.items()) if point else "-"


@dataclass
class Study:
    file: str
    text: str = ""
    title: str = ""
    reference: str = ""
    systems: list[System] = field(default_factory=list)
    cases: list[Case] = field(default_factory=list)
    seeds: list[int] = field(default_factory=list)
    sweeps: list[Sweep] = field(default_factory=list)
    problems: list[Problem] = field(default_factory=list)

    def problem(self, line: int, message: str, item: str = "") -> None:
        self.problems.append(Problem(self.file, line, "", item, message))

    def points(self, system: str) -> list[dict[str, Any]]:
        """The sweep points a system runs at ([{}]: no sweep)."""
        for sweep in self.sweeps:
            if system in sweep.systems:
                return sweep.points()
        return [{}]

    def point_count(self, system: str) -> int:
        """How many sweep points a system runs at (1: no sweep), by arithmetic."""
        sweep = next((s for s in self.sweeps if system in s.systems), None)
        return sweep.count() if sweep is not None else 1

    def first_point(self, system: str) -> dict[str, Any]:
        """A system's first sweep point ({}: no sweep), without listing the others."""
        sweep = next((s for s in self.sweeps if system in s.systems), None)
        return {k: v[0] for k, v in sweep.values.items()} if sweep is not None else {}

    def system(self, name: str) -> System:
        return next(s for s in self.systems if s.name == name)


def read_study(path: str | Path) -> Study:
    """Read a study file; problems are recorded, never raised."""
    path = Path(path)
    study = Study(file=str(path))
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                study.problem(0, "not a regular file (a FIFO, device or socket): expected a study")
                return study
            with os.fdopen(fd, "rb", closefd=False) as f:
                data = f.read(MAX_GRAPH_BYTES + 1)
        finally:
            os.close(fd)
    except OSError as exc:
        study.problem(0, f"cannot read study file: {exc.strerror or exc}")
        return study
    if len(data) > MAX_GRAPH_BYTES:
        study.problem(0, f"larger than {MAX_GRAPH_BYTES // 1024} KiB: not a study file")
        return study
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        study.problem(data[: exc.start].count(b"\n") + 1, "not UTF-8 text")
        return study
    return parse_study(text, str(path))


def _line(node: yaml.Node) -> int:
    return node.start_mark.line + 1


def parse_study(text: str, file: str = "<study>") -> Study:
    study = Study(file=file, text=text)
    study.problems += structure_problems(text, file, "study file")
    if study.problems:
        return study
    try:
        loader = Loader(text)
        root = loader.get_single_node()
        yaml.load(text, Loader=Loader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else 0
        study.problem(line, f"malformed YAML: {getattr(exc, 'problem', None) or exc}")
        return study
    if not isinstance(root, yaml.MappingNode):
        study.problem(1, "expected a mapping with keys format, systems, cases, seeds")
        return study

    def value(node: yaml.Node) -> Any:
        return loader.construct_object(node, deep=True)

    top = _mapping(study, root, "the study")
    for key, (knode, _) in top.items():
        if key not in TOP_KEYS:
            study.problem(_line(knode), f"unknown key {key!r} (expected {', '.join(TOP_KEYS)})")
    if "format" not in top:
        study.problem(1, f"missing 'format: {FORMAT}'")
    elif value(top["format"][1]) != FORMAT:
        study.problem(
            _line(top["format"][1]),
            f"unknown format {value(top['format'][1])!r}, expected {FORMAT!r}",
        )
    if "title" in top:
        study.title = str(value(top["title"][1]))
    base = Path(file).parent
    for key in ("systems", "cases"):
        if key not in top:
            study.problem(1, f"missing {key!r}")
    if "systems" in top:
        _read_systems(study, top["systems"][1], value, base)
    if "cases" in top:
        _read_cases(study, top["cases"][1], value, base)
    study.seeds = [0]
    if "seeds" in top:
        node = top["seeds"][1]
        seeds = value(node)
        seeds = [seeds] if isinstance(seeds, int) and not isinstance(seeds, bool) else seeds
        if (
            not isinstance(seeds, list)
            or not seeds
            or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds)
        ):
            study.problem(_line(node), "'seeds' must be a whole number >= 0 or a list of them")
        elif len(set(seeds)) != len(seeds):
            study.problem(_line(node), "'seeds' lists a seed twice")
        else:
            study.seeds = list(seeds)
    names = [s.name for s in study.systems]
    if "reference" in top:
        node = top["reference"][1]
        study.reference = str(value(node))
        if study.reference not in names:
            study.problem(
                _line(node),
                f"reference {study.reference!r} is not a system of the study "
                f"(systems: {', '.join(names) or 'none'})",
            )
    elif names:
        study.reference = names[0]
    if "sweeps" in top:
        _read_sweeps(study, top["sweeps"][1], value)
    return study


def _mapping(study: Study, node: yaml.Node, what: str) -> dict[Any, tuple[yaml.Node, yaml.Node]]:
    out: dict[Any, tuple[yaml.Node, yaml.Node]] = {}
    if not isinstance(node, yaml.MappingNode):
        study.problem(_line(node), f"{what} must be a mapping")
        return out
    for k, v in node.value:
        key = k.value if isinstance(k, yaml.ScalarNode) else str(k)
        if key in out:
            study.problem(_line(k), f"{what}: key {key!r} given twice")
            continue
        out[key] = (k, v)
    return out


def _entries(study: Study, node: yaml.Node, what: str) -> list[yaml.MappingNode]:
    if not isinstance(node, yaml.SequenceNode) or not node.value:
        study.problem(_line(node), f"'{what}' must be a non-empty list of mappings")
        return []
    out = []
    for item in node.value:
        if isinstance(item, yaml.MappingNode):
            out.append(item)
        else:
            study.problem(_line(item), f"an entry of '{what}' must be a mapping")
    return out


def _name(study: Study, entry: dict[str, Any], line: int, what: str, seen: dict[str, int]) -> str:
    name = str(entry.get("name", ""))
    if not NAME.match(name):
        study.problem(
            line,
            f"{what} name {name!r}: expected 1-64 letters, digits, '_', '.', '+' or '-' "
            "(it names folders)",
        )
    elif name in seen:
        study.problem(line, f"duplicate {what} name {name!r} (also line {seen[name]})")
    else:
        seen[name] = line
    return name


def _keys(study: Study, m: dict[str, Any], allowed: tuple[str, ...], what: str) -> None:
    for key, (knode, _) in m.items():
        if key not in allowed:
            study.problem(
                _line(knode), f"{what}: unknown key {key!r} (expected {', '.join(allowed)})"
            )


def _read_systems(study: Study, node: yaml.Node, value: Any, base: Path) -> None:
    seen: dict[str, int] = {}
    for item in _entries(study, node, "systems"):
        m = _mapping(study, item, "a system")
        _keys(study, m, ("name", "graph", "set"), "system")
        entry = {k: value(v) for k, (_, v) in m.items()}
        name = _name(study, entry, _line(item), "system", seen)
        graph = entry.get("graph")
        if not isinstance(graph, str) or not graph.strip():
            study.problem(_line(item), f"system {name!r}: 'graph' must name a graph file")
            graph = ""
        overrides: dict[str, Any] = {}
        lines: dict[str, int] = {}
        if "set" in m:
            sm = _mapping(study, m["set"][1], f"system {name!r}: 'set'")
            for key, (knode, vnode) in sm.items():
                if "." not in str(key):
                    study.problem(_line(knode), f"system {name!r}: set {key}: expected BLOCK.PARAM")
                    continue
                overrides[str(key)] = value(vnode)
                lines[str(key)] = _line(knode)
        study.systems.append(System(name, base / graph, overrides, _line(item), lines))


def _read_cases(study: Study, node: yaml.Node, value: Any, base: Path) -> None:
    from pasim_graph.graph import parse_sector

    seen: dict[str, int] = {}
    for item in _entries(study, node, "cases"):
        m = _mapping(study, item, "a case")
        keys = ("name", "truth", "sector", "elevation", "sweeps", "interpolation", "fields")
        _keys(study, m, keys, "case")
        entry = {k: value(v) for k, (_, v) in m.items()}
        line = _line(item)
        name = _name(study, entry, line, "case", seen)
        truth = entry.get("truth") or ""
        if not isinstance(truth, str):
            study.problem(line, f"case {name!r}: 'truth' must be a file name ('' = bundled scene)")
            truth = ""
        elif truth.strip():
            truth = str(base / truth)
            if not Path(truth).is_file():
                what = "not found" if not Path(truth).exists() else "not a regular file"
                study.problem(line, f"case {name!r}: truth {truth}: {what}")
        sector_text = str(entry.get("sector", "0:360"))
        sector, problem = parse_sector(sector_text)
        if problem:
            study.problem(line, f"case {name!r}: sector {sector_text}: {problem}")
        elevation = entry.get("elevation", 0.5)
        if isinstance(elevation, bool) or not isinstance(elevation, (int, float)):
            study.problem(line, f"case {name!r}: elevation {elevation!r}: expected degrees")
            elevation = 0.5
        elif not -2.0 <= elevation <= 90.0:
            study.problem(line, f"case {name!r}: elevation {elevation:g} deg: outside -2 to 90")
        sweeps = _choice(study, line, name, entry, "sweeps", CASE_SWEEPS)
        interpolation = _choice(study, line, name, entry, "interpolation", CASE_INTERPOLATIONS)
        if "interpolation" in entry and sweeps != "volume":
            study.problem(line, f"case {name!r}: 'interpolation' needs sweeps: volume")
        fields = entry.get("fields") or {}
        wrong = _fields_problem(fields)
        if wrong:
            study.problem(line, f"case {name!r}: fields {fields!r}: {wrong}")
            fields = {}
        study.cases.append(
            Case(
                name,
                truth,
                sector or (0.0, 360.0),
                float(elevation),
                line,
                sweeps,
                interpolation,
                dict(fields),
            )
        )


def _fields_problem(fields: Any) -> str | None:
    """What is wrong with a case's ``fields`` (moment -> the truth file's field), as the
    truth block's parameter of that name checks it."""
    from pasim_graph.fm301 import MOMENT_FIELDS
    from pasim_graph.ports import Param

    return Param(None, type="mapping", choices=MOMENT_FIELDS, optional=True).check(fields)


def _choice(
    study: Study, line: int, name: str, entry: dict[str, Any], key: str, choices: tuple[str, ...]
) -> str:
    given = entry.get(key, choices[0])
    if given not in choices:
        study.problem(line, f"case {name!r}: {key} {given!r}: expected one of {', '.join(choices)}")
        return choices[0]
    return str(given)


def _read_sweeps(study: Study, node: yaml.Node, value: Any) -> None:
    names = [s.name for s in study.systems]
    taken: dict[str, int] = {}
    for item in _entries(study, node, "sweeps"):
        m = _mapping(study, item, "a sweep")
        _keys(study, m, ("systems", "values"), "sweep")
        line = _line(item)
        systems = value(m["systems"][1]) if "systems" in m else list(names)
        if not isinstance(systems, list) or not all(isinstance(s, str) for s in systems):
            study.problem(line, "sweep: 'systems' must be a list of system names")
            systems = []
        for s in systems:
            if s not in names:
                study.problem(line, f"sweep: {s!r} is not a system of the study")
            elif s in taken:
                study.problem(line, f"sweep: system {s!r} is swept twice (also line {taken[s]})")
            else:
                taken[s] = line
        values: dict[str, list[Any]] = {}
        lines: dict[str, int] = {}
        if "values" not in m:
            study.problem(line, "sweep: missing 'values' (PARAM: [VALUE, ...])")
        else:
            vm = _mapping(study, m["values"][1], "sweep values")
            if not 1 <= len(vm) <= 2:
                study.problem(line, f"sweep: {len(vm)} parameters; a sweep takes one or two")
            for key, (knode, vnode) in vm.items():
                v = value(vnode)
                if "." not in str(key):
                    study.problem(_line(knode), f"sweep {key}: expected BLOCK.PARAM")
                elif not isinstance(v, list) or not v:
                    study.problem(_line(knode), f"sweep {key}: expected a non-empty list of values")
                elif len({repr(x) for x in v}) != len(v):
                    study.problem(_line(knode), f"sweep {key}: a value is given twice")
                else:
                    values[str(key)] = v
                    lines[str(key)] = _line(knode)
        study.sweeps.append(Sweep([s for s in systems if s in names], values, line, lines))
