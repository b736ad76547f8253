"""The graph model: a validated network of blocks on networkx.

:func:`resolve` is the one path from a graph file and a user's choices (parameter overrides,
a truth file, a sector) to a validated graph; the command line, the studio and :func:`load`
all go through it. It validates everything before any computation, collecting every problem
(Hamilton-style) into one :class:`GraphError`.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import networkx as nx

from . import registry
from .block import Block
from .graphfile import (
    ConnectionSpec,
    Endpoint,
    GraphSpec,
    Problem,
    dumps,
    parse_value,
    read,
)
from .steering import nominal_problems
from .sweep_level import stage_problems


class GraphError(Exception):
    """Every problem found in a graph, reported together."""

    def __init__(self, problems: list[Problem]):
        self.problems = sorted(set(problems))
        super().__init__(self.report())

    def report(self) -> str:
        n = len(self.problems)
        head = f"{n} problem{'s' if n != 1 else ''} in the graph:"
        return "\n".join([head, *(f"  {p}" for p in self.problems)])


@dataclass(frozen=True)
class Edge:
    src: str
    src_port: str
    dst: str
    dst_port: str


class Graph:
    """A validated graph: block classes, resolved parameters and typed edges.

    Built by :func:`load` or :func:`validate`; ``nx`` is the underlying
    ``networkx.MultiDiGraph`` (nodes are block names, edges carry port names).
    """

    def __init__(
        self,
        spec: GraphSpec,
        classes: dict[str, type[Block]],
        params: dict[str, dict[str, Any]],
        edges: list[Edge],
    ):
        self.spec = spec
        self.classes = classes
        self.params = params
        self.edges = edges
        self.nx = nx.MultiDiGraph()
        for name in sorted(classes):
            self.nx.add_node(name, cls=classes[name])
        for e in edges:
            self.nx.add_edge(e.src, e.dst, src_port=e.src_port, dst_port=e.dst_port)

    def order(self) -> list[str]:
        """Blocks in a deterministic topological order."""
        return list(nx.lexicographical_topological_sort(self.nx))

    def inputs_of(self, block: str) -> list[Edge]:
        return [e for e in self.edges if e.dst == block]

    def by_role(self, role: str) -> list[str]:
        return sorted(n for n, c in self.classes.items() if c.role == role)

    def value(self, block: str, param: str) -> Any:
        """The value a block's parameter runs with: the graph's, or the class default."""
        return self.params[block].get(param, self.classes[block].params[param].default)

    def at_expected_level(self) -> bool:
        """True when a block that declares a fidelity parameter (``Block.fidelity_param``)
        runs at its declared ``Block.expected_level``: the run draws no time series. Read
        from the classes' declarations and the parameter values, never from a parameter's
        name; the executors hand it to every block as ``Chunk.expected``."""
        return any(
            bool(cls.fidelity_param and cls.expected_level)
            and self.value(name, cls.fidelity_param) == cls.expected_level
            for name, cls in self.classes.items()
        )

    def build(self) -> dict[str, Block]:
        """Instantiate every block with its resolved parameters; each carries the type name its
        graph file gave it (a class registered under two names has two)."""
        blocks = {n: self.classes[n](name=n, **self.params[n]) for n in self.order()}
        for n, block in blocks.items():
            block.__dict__["type_name"] = self.spec.blocks[n].type
        return blocks

    def text(self) -> str:
        return dumps(self.spec)

    def to_json(self) -> dict[str, Any]:
        return {
            "file": self.spec.file,
            "blocks": {
                n: {"type": self.spec.blocks[n].type, "params": self.params[n]}
                for n in sorted(self.classes)
            },
            "connections": sorted(
                f"{e.src}.{e.src_port} -> {e.dst}.{e.dst_port}" for e in self.edges
            ),
        }


def load(path: str | Path, overrides: dict[str, Any] | None = None) -> Graph:
    """Read, override and validate a graph file; raise :class:`GraphError` listing every problem.

    The graph :func:`resolve` gives (so the same as ``pasim validate`` and ``pasim run``).
    """
    return resolve(path, overrides).graph


class Resolved(NamedTuple):
    """A validated graph and every parameter override it got (the user's and the derived)."""

    graph: Graph
    overrides: dict[str, Any]


#: How :func:`resolve` names each choice in a problem; the command line names its options.
LABELS = {"set": "set", "truth": "truth", "sector": "sector"}


def resolve(
    graph: GraphSpec | str | Path,
    overrides: Mapping[str, Any] | None = None,
    *,
    settings: Sequence[str] = (),
    truth: str | Path | None = None,
    sector: str | None = None,
    labels: Mapping[str, str] = LABELS,
) -> Resolved:
    """The one path from a graph and a user's choices to a validated :class:`Graph`.

    ``overrides`` (``{"block.param": value}``) and ``settings`` (``"BLOCK.PARAM=VALUE"``
    text, as ``pasim run --set`` takes it) set parameters. ``truth`` sets the ``path`` of
    the graph's one truth-role block and ``sector`` (``"AZ0:AZ1"``, :func:`parse_sector`)
    the azimuth sector of its one scan-role block. Then a truth block that can read a sector
    reads only the scan's (:func:`truth_sector`). Every problem, of the graph and of the
    choices, is raised at once in one :class:`GraphError`; ``labels`` names the choices in
    it (the command line passes its option names).
    """
    spec = graph if isinstance(graph, GraphSpec) else read(graph)
    where = {**LABELS, **labels}
    parsed, bad = parse_overrides(list(settings))
    chosen = {**(overrides or {}), **parsed}
    problems = [
        Problem(spec.file, 0, "", f"{where['set']} {b}", "expected BLOCK.PARAM=VALUE") for b in bad
    ]
    seen: dict[str, str] = {}
    for item in settings:
        key = item.partition("=")[0].strip()
        if key in seen and "." in key:
            problems.append(
                Problem(
                    spec.file,
                    0,
                    "",
                    f"{where['set']} {item}",
                    f"{key} is set twice (also {where['set']} {seen[key]})",
                )
            )
        seen.setdefault(key, item)
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

    def conflict(option: str, key: str) -> bool:
        if key in chosen:
            problems.append(
                Problem(
                    spec.file,
                    0,
                    "",
                    option,
                    f"sets {key} and so does {where['set']} {key}: give one",
                )
            )
            return True
        return False

    if truth is not None and not str(truth).strip():
        problems.append(
            Problem(
                spec.file,
                0,
                "",
                where["truth"],
                "is empty (an unset shell variable?): give a radar file, or leave "
                f"{where['truth']} out for the graph's own truth",
            )
        )
    elif truth is not None:
        block = by_role("truth", where["truth"])
        if block and not conflict(where["truth"], f"{block}.path"):
            chosen[f"{block}.path"] = str(truth)
    if sector is not None:
        block = by_role("scan", where["sector"])
        azimuths, problem = parse_sector(sector)
        if problem:
            problems.append(Problem(spec.file, 0, "", f"{where['sector']} {sector}", problem))
        elif block and azimuths:
            keys = (f"{block}.azimuth_start_deg", f"{block}.azimuth_stop_deg")
            if not any([conflict(where["sector"], k) for k in keys]):
                chosen[keys[0]], chosen[keys[1]] = azimuths
    try:
        result = validate(spec, chosen)
    except GraphError as exc:
        raise GraphError(exc.problems + problems) from None
    if problems:
        raise GraphError(problems)
    derived = truth_sector(result)
    if derived:
        chosen |= derived
        result = validate(spec, chosen)
    return Resolved(result, chosen)


def parse_sector(text: str) -> tuple[tuple[float, float] | None, str | None]:
    """``AZ0:AZ1`` in degrees clockwise, as (start, stop) in [0, 360], or a problem.

    Angles outside 0-360 are taken modulo 360, so ``-10:10`` is the 20 deg sector through
    north (``350:10``); ``0:360`` is the full circle; equal ends (``10:10``) are refused,
    since they name no sector.
    """
    try:
        a0, a1 = (float(x) for x in text.split(":"))
    except ValueError:
        return None, "expected AZ0:AZ1 in degrees clockwise (e.g. 240:330, or 350:10 through north)"
    if not (math.isfinite(a0) and math.isfinite(a1)):
        return None, "expected finite angles in degrees"
    if a0 == a1:
        return None, (
            f"the sector starts and stops at {a0:g} deg and holds no beam; for the full circle "
            "give 0:360"
        )
    if a1 - a0 > 360.0:
        return None, f"the sector spans {a1 - a0:g} deg, more than the full circle (0:360)"
    start = a0 % 360.0
    stop = a1 % 360.0
    if stop == 0.0 and a1 != 0.0 and start == 0.0:
        stop = 360.0  # 0:360 and -360:0 are the full circle
    return (start, stop), None


def truth_sector(graph: Graph) -> dict[str, Any]:
    """Let a truth block that can read a sector read only the scan's (plus its margin).

    Applies when there is one truth and one scan block, both declare ``azimuth_start_deg`` and
    ``azimuth_stop_deg``, and the truth's sector is not set already. Returns the overrides.
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


def parse_overrides(items: list[str]) -> tuple[dict[str, Any], list[str]]:
    """Turn ``BLOCK.PARAM=VALUE`` strings into overrides; return them and the malformed ones."""
    out: dict[str, Any] = {}
    bad = []
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or "." not in key:
            bad.append(item)
            continue
        out[key.strip()] = parse_value(value)
    return out, bad


def validate(spec: GraphSpec, overrides: dict[str, Any] | None = None) -> Graph:
    """Check a parsed graph completely; return the :class:`Graph` or raise :class:`GraphError`."""
    # Overrides go into a copy: the caller's spec stays as read; the graph keeps the copy,
    # so the text stored with a run says what actually ran.
    spec = copy.deepcopy(spec)
    problems = list(spec.problems)
    f = spec.file
    for key, value in (overrides or {}).items():
        block, _, param = key.partition(".")
        if block not in spec.blocks:
            known = ", ".join(sorted(spec.blocks)) or "none"
            problems.append(
                Problem(
                    f,
                    0,
                    block,
                    f"--set {key}",
                    f"no block named {block!r} in the graph (blocks: {known})",
                )
            )
            continue
        spec.blocks[block].params[param] = value
        spec.blocks[block].param_lines.setdefault(param, 0)

    classes: dict[str, type[Block]] = {}
    params: dict[str, dict[str, Any]] = {}
    for name, b in spec.blocks.items():
        cls = registry.get(b.type)
        if cls is None:
            err = registry.load_error(b.type)
            if err:
                msg = f"block type {b.type!r} is registered but failed to load: {err}"
            else:
                near = registry.closest(b.type)
                hint = f"; closest known: {', '.join(near)}" if near else ""
                msg = f"unknown block type {b.type!r}{hint} (see `pasim blocks`)"
            problems.append(Problem(f, b.line, name, "type", msg))
            continue
        classes[name] = cls
        params[name] = _check_params(spec, name, cls, problems)
        for item, message in cls.interface_problems():
            problems.append(
                Problem(f, b.line, name, item, f"block type {b.type} is faulty: {message}")
            )

    edges = _check_connections(spec, classes, problems)

    for name, cls in classes.items():
        connected = {e.dst_port for e in edges if e.dst == name}
        for item, message in cls.check_config(params[name], connected):
            problems.append(Problem(f, spec.blocks[name].line, name, item, message))
        for port in cls.inputs.values():
            if port.required and port.name not in connected:
                problems.append(
                    Problem(
                        f,
                        spec.blocks[name].line,
                        name,
                        f"port '{port.name}'",
                        f"required input is not connected (expects {port.type.describe()})",
                    )
                )

    g = nx.DiGraph()
    g.add_edges_from((e.src, e.dst) for e in edges)
    # networkx finds cycles in an order that follows set iteration; each is started at its
    # first name and the list sorted, so the message is the same on every run.
    cycles = []
    for found in nx.simple_cycles(g):
        first = found.index(min(found))
        cycles.append(found[first:] + found[:first])
    for cycle in sorted(cycles):
        path = " -> ".join([*cycle, cycle[0]])
        problems.append(
            Problem(f, spec.blocks[cycle[0]].line, cycle[0], "connections", f"cycle: {path}")
        )

    for block, message in stage_problems(classes, edges):
        problems.append(Problem(f, spec.blocks[block].line, block, "connections", message))

    if spec.blocks_read and not spec.blocks:
        problems.append(
            Problem(f, 0, "", "blocks", "the graph has no blocks (a run needs at least a scan)")
        )
    sources = sorted(n for n, c in classes.items() if c.beam_source)
    if classes and len(classes) == len(spec.blocks) and len(sources) != 1:
        problems.append(
            Problem(
                f,
                0,
                "",
                "blocks",
                "expected exactly one block that defines the beams (a scan), "
                f"found {len(sources)}: {', '.join(sources) or 'none'}",
            )
        )
    if problems:
        raise GraphError(problems)
    graph = Graph(spec, classes, params, edges)
    # Beams a block cannot point at (behind a planar face): refused before any run.
    steering = nominal_problems(graph)
    if steering:
        raise GraphError(steering)
    return graph


def _check_params(
    spec: GraphSpec, name: str, cls: type[Block], problems: list[Problem]
) -> dict[str, Any]:
    f = spec.file
    b = spec.blocks[name]
    values: dict[str, Any] = {}
    for key, raw in b.params.items():
        line = b.param_lines.get(key) or b.line
        decl = cls.params.get(key)
        if decl is None:
            near = [p for p in cls.params if p.startswith(key[:3])] or sorted(cls.params)
            problems.append(
                Problem(
                    f,
                    line,
                    name,
                    f"parameter '{key}'",
                    f"unknown parameter of {b.type}; known: {', '.join(near)}",
                )
            )
            continue
        value = raw
        if isinstance(raw, str) and raw.startswith("$"):
            var = raw[1:]
            if var not in spec.variables:
                problems.append(
                    Problem(f, line, name, f"parameter '{key}'", f"undefined variable ${var}")
                )
                continue
            value = spec.variables[var]
        if decl.type == "float" and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        err = decl.check(value)
        if err:
            problems.append(Problem(f, line, name, f"parameter '{key}'", err))
            continue
        values[key] = value
    for decl in cls.params.values():
        if decl.required and decl.name not in b.params:
            problems.append(
                Problem(
                    f,
                    b.line,
                    name,
                    f"parameter '{decl.name}'",
                    f"required parameter missing ({decl.doc})",
                )
            )
    return values


def _resolve(
    spec: GraphSpec,
    end: Endpoint,
    ports: dict[str, Any],
    side: str,
    line: int,
    problems: list[Problem],
) -> str | None:
    meant = end.port_in(ports)
    if meant is not None:
        return meant
    if end.port is None:
        listed = ", ".join(ports) or "none"
        problems.append(
            Problem(
                spec.file,
                line,
                end.block,
                f"{side}s",
                f"name the port: the block has {len(ports)} {side}s ({listed})",
            )
        )
        return None
    listed = ", ".join(ports) or "none"
    problems.append(
        Problem(
            spec.file,
            line,
            end.block,
            f"port '{end.port}'",
            f"no {side} port named {end.port!r}; {side}s: {listed}",
        )
    )
    return None


def _check_connections(
    spec: GraphSpec, classes: dict[str, type[Block]], problems: list[Problem]
) -> list[Edge]:
    edges = []
    fed: dict[tuple[str, str], ConnectionSpec] = {}
    for c in spec.connections:
        ok = True
        for end in (c.src, c.dst):
            if end.block not in spec.blocks:
                problems.append(
                    Problem(
                        spec.file,
                        c.line,
                        end.block,
                        f"connection '{c}'",
                        f"no block named {end.block!r}",
                    )
                )
                ok = False
        if not ok or c.src.block not in classes or c.dst.block not in classes:
            continue
        src_cls, dst_cls = classes[c.src.block], classes[c.dst.block]
        sp = _resolve(spec, c.src, src_cls.outputs, "output", c.line, problems)
        dp = _resolve(spec, c.dst, dst_cls.inputs, "input", c.line, problems)
        if sp is None or dp is None:
            continue
        out_t, in_t = src_cls.outputs[sp].type, dst_cls.inputs[dp].type
        diff = out_t.mismatch(in_t)
        if diff:
            problems.append(
                Problem(
                    spec.file,
                    c.line,
                    c.dst.block,
                    f"port '{dp}'",
                    f"incompatible types in '{c}': output {c.src.block}.{sp} is "
                    f"{out_t.describe()}, input expects {in_t.describe()} ({'; '.join(diff)})",
                )
            )
            continue
        if (c.dst.block, dp) in fed:
            problems.append(
                Problem(
                    spec.file,
                    c.line,
                    c.dst.block,
                    f"port '{dp}'",
                    f"input already fed by '{fed[(c.dst.block, dp)]}'",
                )
            )
            continue
        fed[(c.dst.block, dp)] = c
        edges.append(Edge(c.src.block, sp, c.dst.block, dp))
    return edges
