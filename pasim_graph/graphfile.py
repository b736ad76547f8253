"""The graph text format (YAML) read with line numbers, and written back in canonical order.

```yaml
format: pasim-graph/1
variables: {prt_s: 3.333e-3}
blocks:
  tx:  {type: waveform.rectangular, params: {width_s: 1.6e-6}}
  hpa: {type: amplifier.saleh}
connections:
  - tx.pulse -> hpa.pulse
```
Blocks and ports are named, never indexed; a port may be left out when the block has only one
on that side. ``$name`` refers to a variable. Reading never raises on bad content: it records
:class:`Problem` s, so that validation can report every problem at once.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

FORMAT = "pasim-graph/1"


@dataclass(frozen=True, order=True)
class Problem:
    """One thing wrong with a graph, located as precisely as possible."""

    file: str
    line: int
    block: str = ""
    item: str = ""  # "port 'x'", "parameter 'y'", "connection '...'"
    message: str = ""

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}" if self.line else self.file
        what = ", ".join(x for x in (f"block '{self.block}'" if self.block else "", self.item) if x)
        return f"{where}: {what}: {self.message}" if what else f"{where}: {self.message}"

    def to_json(self) -> dict[str, Any]:
        return {
            "file": self.file,
            "line": self.line,
            "block": self.block,
            "item": self.item,
            "message": self.message,
        }


@dataclass
class BlockSpec:
    type: str
    params: dict[str, Any] = field(default_factory=dict)
    line: int = 0
    param_lines: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class Endpoint:
    block: str
    port: str | None

    def __str__(self) -> str:
        return f"{self.block}.{self.port}" if self.port else self.block

    def port_in(self, ports: Iterable[str]) -> str | None:
        """The port this wire end means among a block's ports on its side: the one it names,
        if the block has it, or, when it names none, the block's only port; else None.

        The one rule the validator, the graph pictures and the studio's swaps share.
        """
        names = list(ports)
        if self.port is None:
            return names[0] if len(names) == 1 else None
        return self.port if self.port in names else None


@dataclass
class ConnectionSpec:
    src: Endpoint
    dst: Endpoint
    line: int = 0

    def __str__(self) -> str:
        return f"{self.src} -> {self.dst}"


@dataclass
class GraphSpec:
    """A graph file as written: block types, raw parameter values, connections."""

    file: str = "<graph>"
    format: str = FORMAT
    variables: dict[str, Any] = field(default_factory=dict)
    blocks: dict[str, BlockSpec] = field(default_factory=dict)
    connections: list[ConnectionSpec] = field(default_factory=list)
    problems: list[Problem] = field(default_factory=list)
    #: The file had a readable ``blocks`` mapping (possibly empty).
    blocks_read: bool = False

    def problem(self, line: int, message: str, block: str = "", item: str = "") -> None:
        self.problems.append(Problem(self.file, line, block, item, message))


#: libyaml's parser where PyYAML was built with it (every wheel on PyPI is): graph files are read
#: three times (events, nodes, values), and the pure-Python scanner took 24 ms per file.
_SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class _Loader(_SAFE_LOADER):  # type: ignore[valid-type,misc]
    """SafeLoader with YAML 1.2 core-schema scalars.

    PyYAML follows YAML 1.1, where ``1_0`` is the integer 10, ``4:40`` the sexagesimal 280,
    ``010`` octal 8 and ``on``/``no`` booleans: a typo became another number without a word.
    Here integers are ``[-+]?[0-9]+`` (and ``0x``/``0o``), floats as YAML 1.2 writes them (``1e-6``
    included), booleans ``true``/``false``; anything else stays text, which a parameter's
    check then refuses by name.
    """


_Loader.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in resolvers if not tag.endswith((":int", ":float", ":bool"))]
    for first, resolvers in _SAFE_LOADER.yaml_implicit_resolvers.items()
}

_FLOAT = re.compile(
    r"""^(?:[-+]?(?:[0-9]+)\.[0-9]*(?:[eE][-+]?[0-9]+)?
    |[-+]?(?:[0-9]+)(?:[eE][-+]?[0-9]+)
    |[-+]?\.[0-9]+(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""",
    re.X,
)
_INT = re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$")
_BOOL = re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$")
_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+0123456789."))
_Loader.add_implicit_resolver("tag:yaml.org,2002:int", _INT, list("-+0123456789"))
_Loader.add_implicit_resolver("tag:yaml.org,2002:bool", _BOOL, list("tTfF"))
#: The YAML 1.2 scalar rules, public for the project's other YAML formats (study files).
Loader = _Loader


def _construct_int(loader: yaml.SafeLoader, node: yaml.Node) -> int:
    text = str(loader.construct_scalar(node))  # type: ignore[arg-type]
    if text.startswith(("0o", "0x")):
        return int(text, 0)
    return int(text, 10)  # leading zeros are decimal in YAML 1.2 (``010`` is 10)


_Loader.add_constructor("tag:yaml.org,2002:int", _construct_int)

#: Graph files are a few kilobytes; a bound keeps a wrong path (a disk image, /dev/zero)
#: from being read whole.
MAX_GRAPH_BYTES = 1 << 20
#: Deeper nesting than a graph file ever needs (blocks > name > params > value) is refused
#: before it is built.
MAX_DEPTH = 32


class _Dumper(yaml.SafeDumper):
    """Quotes strings that :class:`_Loader` would read back as floats."""


_Dumper.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+0123456789."))

_ENDPOINT = r"([A-Za-z_][\w-]*)(?:\.(\w+))?"
_CONNECTION = re.compile(rf"^\s*{_ENDPOINT}\s*->\s*{_ENDPOINT}\s*$")
#: What a block name may be (a graph file's, the studio's).
BLOCK_NAME = re.compile(r"^[A-Za-z_][\w-]*$")
#: What a port name may be.
PORT_NAME = re.compile(r"^\w+$")


def _line(node: yaml.Node) -> int:
    return node.start_mark.line + 1


def _value(node: yaml.Node) -> Any:
    # Constructed from the node itself: writing it out and reading it back failed on an empty
    # value (``frequency_hz:`` at the end of a file).
    loader = _Loader("")
    try:
        return loader.construct_document(node)
    finally:
        loader.dispose()


def parse_value(text: str) -> Any:
    """Parse a scalar given on the command line the way the graph file would.

    Text that is not valid YAML (``@``, ``*a``, ``!!python/...``) stays the text it is, for
    the parameter's check to refuse it by name (or a ``str`` parameter to take it).
    """
    try:
        return yaml.load(text, Loader=_Loader)
    except yaml.YAMLError:
        return text


def read(path: str | Path) -> GraphSpec:
    """Read a graph file; problems (unreadable, malformed) are recorded, never raised."""
    import os
    import stat

    path = Path(path)
    try:
        # O_NONBLOCK: opening a FIFO with no writer must not hang; a FIFO or device is then
        # refused by its type before anything is read.
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                spec = GraphSpec(file=str(path))
                spec.problem(
                    0, "not a regular file (a FIFO, device or socket): expected a graph file"
                )
                return spec
            with os.fdopen(fd, "rb", closefd=False) as f:
                data = f.read(MAX_GRAPH_BYTES + 1)
        finally:
            os.close(fd)
    except OSError as exc:
        spec = GraphSpec(file=str(path))
        spec.problem(0, f"cannot read graph file: {exc.strerror or exc}")
        return spec
    if len(data) > MAX_GRAPH_BYTES:
        spec = GraphSpec(file=str(path))
        spec.problem(0, f"larger than {MAX_GRAPH_BYTES // 1024} KiB: not a graph file")
        return spec
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        spec = GraphSpec(file=str(path))
        line = data[: exc.start].count(b"\n") + 1
        spec.problem(
            line,
            f"not UTF-8 text: byte 0x{data[exc.start]:02x} at offset {exc.start} cannot be "
            "decoded (save the graph file as UTF-8)",
        )
        return spec
    return parse(text, str(path))


def parse(text: str, file: str = "<graph>") -> GraphSpec:
    spec = GraphSpec(file=file)
    if _refuse_structure(spec, text):
        return spec
    try:
        root = yaml.compose(text, Loader=_Loader)
        # Composing lets through tags the safe loader refuses to construct (!!python/...);
        # constructing the document once finds them, with their line.
        yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else 0
        problem = getattr(exc, "problem", None) or str(exc)
        spec.problem(line, f"malformed YAML: {problem}")
        return spec
    if not isinstance(root, yaml.MappingNode):
        spec.problem(
            _line(root) if root else 1,
            "expected a mapping with keys 'format', 'blocks' and 'connections'",
        )
        return spec
    _duplicate_keys(spec, root, "")
    sections = _first(root)
    for key, (knode, _) in sections.items():
        if key not in ("format", "variables", "blocks", "connections"):
            spec.problem(
                _line(knode),
                f"unknown top-level key {key!r} (expected format, variables, blocks, connections)",
            )
    if "format" not in sections:
        spec.problem(1, f"missing 'format: {FORMAT}'")
    else:
        spec.format = str(_value(sections["format"][1]))
        if spec.format != FORMAT:
            spec.problem(
                _line(sections["format"][1]),
                f"unknown format version {spec.format!r}, expected {FORMAT!r}",
            )
    if "variables" in sections:
        node = sections["variables"][1]
        if isinstance(node, yaml.MappingNode):
            spec.variables = {k: _value(v) for k, (_, v) in _first(node).items()}
        elif not _is_null(node):
            spec.problem(_line(node), "'variables' must be a mapping of name: value")
    if "blocks" not in sections:
        spec.problem(1, "missing 'blocks'")
    else:
        _read_blocks(spec, sections["blocks"][1])
    if "connections" in sections:
        _read_connections(spec, sections["connections"][1])
    return spec


def structure_problems(text: str, file: str, kind: str = "graph file") -> list[Problem]:
    """Anchors, aliases and nesting deeper than :data:`MAX_DEPTH` in a YAML text, as problems.

    Public for other YAML formats of the project (study files), so that they refuse the same
    structures as graph files, named for their own ``kind``.
    """
    spec = GraphSpec(file=file)
    _refuse_structure(spec, text, kind)
    return spec.problems


def _refuse_structure(spec: GraphSpec, text: str, kind: str = "graph file") -> bool:
    """Refuse anchors and aliases (a graph file needs none, and nested aliases expand
    exponentially: the "billion laughs") and nesting deeper than :data:`MAX_DEPTH`, from the
    event stream, before any node is built."""
    depth = 0
    try:
        for event in yaml.parse(text, Loader=_Loader):
            line = event.start_mark.line + 1 if event.start_mark else 0
            if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None):
                spec.problem(line, f"anchors and aliases (&name, *name) are not allowed in {kind}s")
                return True
            if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
                depth += 1
                if depth > MAX_DEPTH:
                    spec.problem(line, f"nested deeper than {MAX_DEPTH} levels: not a {kind}")
                    return True
            elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
                depth -= 1
    except yaml.YAMLError as exc:
        if "nesting depth" in str(exc):  # libyaml's own bound, met while scanning ahead
            mark = getattr(exc, "problem_mark", None)
            line = mark.line + 1 if mark is not None else 0
            spec.problem(line, f"nested deeper than {MAX_DEPTH} levels: not a {kind}")
            return True
        return False  # malformed: compose says where, below
    return False


def _first(node: yaml.MappingNode) -> dict[Any, tuple[yaml.Node, yaml.Node]]:
    """Key -> (key node, value node), the first occurrence of each key (duplicates are
    reported by :func:`_duplicate_keys`, never silently resolved to the last one)."""
    out: dict[Any, tuple[yaml.Node, yaml.Node]] = {}
    for k, v in node.value:
        out.setdefault(k.value, (k, v))
    return out


def _duplicate_keys(spec: GraphSpec, node: yaml.Node, where: str) -> None:
    """Record every key written twice in any mapping of the file, with both lines."""
    if isinstance(node, yaml.SequenceNode):
        for item in node.value:
            _duplicate_keys(spec, item, where)
    if not isinstance(node, yaml.MappingNode):
        return
    seen: dict[Any, int] = {}
    for k, v in node.value:
        key = k.value
        path = f"{where}.{key}" if where else str(key)
        if key in seen:
            block = where.split(".")[1] if where.startswith("blocks.") else ""
            if where == "blocks":
                block = str(key)
            spec.problem(
                _line(k),
                f"duplicate key {path!r} (first written at line {seen[key]}); "
                "each key may appear once",
                block=block,
            )
            continue
        seen[key] = _line(k)
        _duplicate_keys(spec, v, path)


def _is_null(node: yaml.Node) -> bool:
    return isinstance(node, yaml.ScalarNode) and node.tag.endswith(":null")


def _read_blocks(spec: GraphSpec, node: yaml.Node) -> None:
    if _is_null(node):
        spec.blocks_read = True
        return
    if not isinstance(node, yaml.MappingNode):
        spec.problem(_line(node), "'blocks' must be a mapping of block name: {type, params}")
        return
    spec.blocks_read = True
    for knode, vnode in node.value:
        name = knode.value
        line = _line(knode)
        if not BLOCK_NAME.match(str(name)):
            spec.problem(line, f"invalid block name {name!r} (letters, digits, _ and -)")
            continue
        if name in spec.blocks:
            continue  # reported as a duplicate key
        if not isinstance(vnode, yaml.MappingNode):
            spec.problem(line, "expected {type: ..., params: {...}}", block=name)
            continue
        fields = _first(vnode)
        for key, (k, _) in fields.items():
            if key not in ("type", "params"):
                spec.problem(
                    _line(k), f"unknown key {key!r} (expected 'type' and 'params')", block=name
                )
        if "type" not in fields:
            spec.problem(line, "missing 'type'", block=name)
            continue
        block = BlockSpec(type=str(_value(fields["type"][1])), line=line)
        if "params" in fields:
            pnode = fields["params"][1]
            if isinstance(pnode, yaml.MappingNode):
                for key, (pk, pv) in _first(pnode).items():
                    block.params[key] = _value(pv)
                    block.param_lines[key] = _line(pk)
            elif not _is_null(pnode):
                spec.problem(_line(pnode), "'params' must be a mapping", block=name)
        spec.blocks[name] = block


def _read_connections(spec: GraphSpec, node: yaml.Node) -> None:
    if _is_null(node):
        return
    if not isinstance(node, yaml.SequenceNode):
        spec.problem(_line(node), "'connections' must be a list of 'a.port -> b.port'")
        return
    for item in node.value:
        text = item.value if isinstance(item, yaml.ScalarNode) else None
        m = _CONNECTION.match(text) if isinstance(text, str) else None
        if not m:
            spec.problem(
                _line(item), f"cannot read connection {text!r}, expected 'block.port -> block.port'"
            )
            continue
        spec.connections.append(
            ConnectionSpec(Endpoint(m[1], m[2]), Endpoint(m[3], m[4]), _line(item))
        )


def dumps(spec: GraphSpec) -> str:
    """Write a graph in canonical form: blocks by name, parameters by name, edges sorted."""
    out = [f"format: {FORMAT}"]
    if spec.variables:
        out.append("variables:")
        for name in sorted(spec.variables):
            out.append(f"  {name}: {format_value(spec.variables[name])}")
    out.append("blocks:")
    width = max((len(n) for n in spec.blocks), default=0) + 1
    for name in sorted(spec.blocks):
        block = spec.blocks[name]
        body: dict[str, Any] = {"type": block.type}
        if block.params:
            body["params"] = {k: block.params[k] for k in sorted(block.params)}
        out.append(f"  {(name + ':').ljust(width)} {format_value(body)}")
    out.append("connections:")
    for text in sorted(str(c) for c in spec.connections):
        out.append(f"  - {text}")
    return "\n".join(out) + "\n"


def format_value(value: Any) -> str:
    """A value as the graph file writes it (YAML flow style): the inverse of
    :func:`parse_value`."""
    text = yaml.dump(value, Dumper=_Dumper, default_flow_style=True, sort_keys=False, width=10**9)
    return text.strip().removesuffix("...").strip()
