"""The graph model: a validated network of blocks on networkx.

:func:`load` reads a graph file, applies command-line overrides and validates everything
before any computation, collecting every problem (Hamilton-style) into one
:class:`GraphError`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path
from typing import Any

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

    def build(self) -> dict[str, Block]:
        """Instantiate every block with its resolved parameters."""
        return {n: self.classes[n](name=n, **self.params[n]) for n in self.order()}

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
    """Read, override and validate a graph file; raise :class:`GraphError` listing every problem."""
    spec = read(path)
    return validate(spec, overrides)


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
    return Graph(spec, classes, params, edges)


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
    if end.port is None:
        if len(ports) == 1:
            return next(iter(ports))
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
    if end.port not in ports:
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
    return end.port


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
