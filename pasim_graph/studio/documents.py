"""Graphs as the studio edits them: JSON documents checked by the engine, swaps, files.

A *document* is a graph file as JSON, lossless in both directions::

    {"format": "pasim-graph/1",
     "variables": {"frequency_hz": "2800000000.0"},
     "blocks": {"hpa": {"type": "amplifier.saleh", "params": {"input_backoff_db": "0.0"}}},
     "connections": [{"src": "tx", "src_port": "pulse", "dst": "hpa", "dst_port": "pulse_in"}]}

Every value is kept as the text the canonical writer gives it (``0.0``, ``$frequency_hz``,
``covariance``): JSON has one number type, and a float ``1.0`` that came back as the integer
``1`` would change the file. A port is ``null`` where the file leaves it out (``tx -> hpa``).
The page never interprets a value; the engine parses and checks it exactly as it does a file
(:func:`check`), so a studio-saved file and a hand-edited one are interchangeable.
"""

from __future__ import annotations

import dataclasses
import difflib
import hashlib
import json
import math
import re
from pathlib import Path
from typing import Any

from .. import registry
from ..graph import GraphError, resolve
from ..graphfile import (
    BLOCK_NAME,
    FORMAT,
    MAX_GRAPH_BYTES,
    PORT_NAME,
    BlockSpec,
    ConnectionSpec,
    Endpoint,
    GraphSpec,
    Problem,
    dumps,
    format_value,
    parse,
    parse_value,
    read,
)
from ..outputs import write_atomic
from .folder import GRAPH_SUFFIXES, Folder, RequestError
from .summary import key_values, system_summary

__all__ = ["GRAPH_SUFFIXES", "Folder", "RequestError", "write_atomic"]

LAYOUT_SUFFIX = ".layout.json"
LAYOUT_FORMAT = "pasim-layout/1"

# Graph files are a few kilobytes (the reader takes at most MAX_GRAPH_BYTES): the bounds
# keep a request's checking to a fraction of a second.
_MAX_TEXT = 4_000
_MAX_BLOCKS = 500
_MAX_CONNECTIONS = 5_000
_MAX_VARIABLES = 1_000
_MAX_PARAMS = 200
#: Characters of names and values a document may hold, checked before any is parsed: 40
#: times the largest example graph (3 kB). Checking costs about 20 ms a kilobyte (PyYAML),
#: so the largest document is answered in a few seconds even on a loaded machine.
_MAX_DOC_TEXT = 128 * 1024
#: A variable's or a parameter's name: an identifier, written unquoted by the canonical
#: writer (``my var: x`` would be read back as another document).
NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
#: A block type's name (``amplifier.saleh``).
TYPE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.-]*")


def sha256(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


# ---------------------------------------------------------------------------------------------
# Documents


def doc_from_spec(spec: GraphSpec) -> dict[str, Any]:
    """A parsed graph as a studio document (values as the canonical writer's text)."""
    return {
        "format": spec.format,
        "variables": {k: format_value(v) for k, v in spec.variables.items()},
        "blocks": {
            name: {"type": b.type, "params": {k: format_value(v) for k, v in b.params.items()}}
            for name, b in spec.blocks.items()
        },
        "connections": [
            {"src": c.src.block, "src_port": c.src.port, "dst": c.dst.block, "dst_port": c.dst.port}
            for c in spec.connections
        ],
    }


def _text(value: Any, where: str) -> Any:
    if not isinstance(value, str):
        raise RequestError(400, f"{where}: expected the value as text, found {_json_type(value)}")
    if len(value) > _MAX_TEXT:
        raise RequestError(400, f"{where}: value longer than {_MAX_TEXT} characters")
    if not value.strip():
        return None
    try:
        return parse_value(value)
    except (ValueError, RecursionError) as exc:
        # A 5,000-digit integer is over Python's limit for converting text to int.
        raise RequestError(400, f"{where}: {value[:40]!r}... is not a value: {exc}") from None


def _size(doc: dict[str, Any]) -> int:
    """Characters of the names and text values a document holds (its YAML-parsed part)."""
    total = 0
    for section in ("variables", "blocks"):
        items = doc.get(section)
        if not isinstance(items, dict):
            continue
        for name, value in items.items():
            total += len(name)
            if isinstance(value, str):
                total += len(value)
            elif isinstance(value, dict):
                total += len(str(value.get("type", "")))
                params = value.get("params")
                if isinstance(params, dict):
                    total += sum(
                        len(k) + (len(v) if isinstance(v, str) else 0) for k, v in params.items()
                    )
    return total


def _name(name: str, what: str) -> None:
    if len(name) > 200 or not NAME.fullmatch(name):
        raise RequestError(
            400,
            f"invalid {what} name {name[:80]!r}: letters, digits and _ only, not first a digit",
        )


def _json_type(value: Any) -> str:
    return {
        dict: "an object",
        list: "a list",
        str: "text",
        bool: "true/false",
        type(None): "null",
    }.get(type(value), "a number")


def mapping(value: Any, where: str) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise RequestError(400, f"{where}: expected an object, found {_json_type(value)}")
    return value


def spec_from_doc(doc: Any, file: str = "<graph>") -> GraphSpec:
    """The graph a document describes; :class:`RequestError` (400) when it is malformed.

    Only the shape is checked here (what the file format itself could not hold); what the
    engine checks (types, parameters, wires) is left to :func:`check`.
    """
    if not isinstance(doc, dict):
        raise RequestError(400, f"'doc': expected a graph document object, found {_json_type(doc)}")
    unknown = sorted(set(doc) - {"format", "variables", "blocks", "connections"})
    if unknown:
        raise RequestError(400, f"'doc': unknown key(s) {', '.join(unknown)}")
    size = _size(doc)
    if size > _MAX_DOC_TEXT:
        raise RequestError(
            400,
            f"'doc': {size} characters of names and values, over the studio's "
            f"{_MAX_DOC_TEXT} (a graph file is a few kilobytes)",
        )
    spec = GraphSpec(file=file, format=str(doc.get("format", FORMAT)))
    variables = mapping(doc.get("variables"), "'doc.variables'")
    if len(variables) > _MAX_VARIABLES:
        raise RequestError(400, f"'doc.variables': more than {_MAX_VARIABLES} variables")
    for name, value in variables.items():
        _name(name, "variable")
        spec.variables[name] = _text(value, f"variable {name!r}")
    blocks = mapping(doc.get("blocks"), "'doc.blocks'")
    if len(blocks) > _MAX_BLOCKS:
        raise RequestError(400, f"'doc.blocks': more than {_MAX_BLOCKS} blocks")
    for name, b in blocks.items():
        if not BLOCK_NAME.fullmatch(name) or len(name) > 200:
            raise RequestError(
                400,
                f"invalid block name {name[:80]!r}: letters, digits, _ and -, not first a digit",
            )
        b = mapping(b, f"block {name!r}")
        extra = sorted(set(b) - {"type", "params"})
        if extra:
            raise RequestError(400, f"block {name!r}: unknown key(s) {', '.join(extra)}")
        btype = b.get("type")
        if not isinstance(btype, str) or not TYPE_NAME.fullmatch(btype) or len(btype) > 200:
            raise RequestError(400, f"block {name!r}: expected 'type', the block type name")
        block = BlockSpec(type=btype)
        params = mapping(b.get("params"), f"block {name!r} 'params'")
        if len(params) > _MAX_PARAMS:
            raise RequestError(400, f"block {name!r}: more than {_MAX_PARAMS} parameters")
        for key, value in params.items():
            _name(key, f"block {name!r}: parameter")
            block.params[key] = _text(value, f"block {name!r}, parameter {key!r}")
        spec.blocks[name] = block
    conns = doc.get("connections") or []
    if not isinstance(conns, list):
        raise RequestError(400, "'doc.connections': expected a list")
    if len(conns) > _MAX_CONNECTIONS:
        raise RequestError(400, f"'doc.connections': more than {_MAX_CONNECTIONS} connections")
    for i, c in enumerate(conns):
        c = mapping(c, f"connection {i + 1}")
        ends = []
        for side in ("src", "dst"):
            end, port = c.get(side), c.get(f"{side}_port")
            if not isinstance(end, str) or not BLOCK_NAME.fullmatch(end):
                raise RequestError(400, f"connection {i + 1}: invalid '{side}' block {end!r}")
            if port is not None and (not isinstance(port, str) or not PORT_NAME.fullmatch(port)):
                raise RequestError(400, f"connection {i + 1}: invalid '{side}_port' {port!r}")
            ends.append(Endpoint(end, port))
        spec.connections.append(ConnectionSpec(ends[0], ends[1]))
    return spec


def canonical(doc: Any, file: str = "<graph>") -> tuple[GraphSpec, str]:
    """The document's canonical text, and the graph as the engine reads that text back.

    Reading the text back (rather than checking the spec directly) gives every problem the
    line it has in the file that saving would write. A document whose text would not read
    back as the same graph is refused (400): nothing is saved or run that reopens otherwise.
    """
    spec = spec_from_doc(doc, file)
    text = dumps(spec)
    if len(text.encode()) > MAX_GRAPH_BYTES:
        raise RequestError(
            400, f"the graph's text would be over {MAX_GRAPH_BYTES} bytes, the graph file limit"
        )
    back = parse(text, file)
    if back.problems or _same(doc_from_spec(back)) != _same(doc_from_spec(spec)):
        why = "; ".join(p.message for p in back.problems[:3]) or "it reads back differently"
        raise RequestError(400, f"the document cannot be written as a graph file: {why}")
    return back, text


def _same(doc: dict[str, Any]) -> dict[str, Any]:
    """A document with its wires in the writer's order (the order carries no meaning)."""
    return doc | {"connections": sorted(doc["connections"], key=json.dumps)}


def path_problems(spec: GraphSpec, folder: Folder) -> tuple[GraphSpec, list[Problem]]:
    """File paths in the graph that leave the served folder, refused before anyone looks.

    Every parameter of type ``path`` (set directly or through a ``$variable``) is checked by
    :meth:`Folder.path_problem`. Returns the graph with those parameters removed (so that
    validation does not test whether the files exist) and a problem naming each one.
    """
    problems: list[Problem] = []
    clean = dataclasses.replace(spec, blocks=dict(spec.blocks))
    for name, b in spec.blocks.items():
        cls = registry.get(b.type)
        if cls is None:
            continue
        for key, raw in b.params.items():
            decl = cls.params.get(key)
            if decl is None or decl.type != "path":
                continue
            value = raw
            if isinstance(raw, str) and raw.startswith("$"):
                value = spec.variables.get(raw[1:])
            if not isinstance(value, str) or not value:
                continue
            why = folder.path_problem(value)
            if why:
                line = b.param_lines.get(key, b.line)
                problems.append(Problem(spec.file, line, name, f"parameter '{key}'", why))
                kept = {k: v for k, v in clean.blocks[name].params.items() if k != key}
                clean.blocks[name] = dataclasses.replace(clean.blocks[name], params=kept)
    return clean, problems


def check(
    doc: Any, file: str, disk: str | None = None, folder: Folder | None = None
) -> dict[str, Any]:
    """The engine's verdict on a document: the problems ``pasim validate`` would print.

    Lines refer to the text the problems are about: the file on disk (``disk``) while the
    document is what it holds, else the canonical text that saving would write. With a
    ``folder``, file paths in the graph that leave it are refused first
    (:func:`path_problems`) and the engine never looks at them.
    """
    spec, text = canonical(doc, file)
    if disk is not None and disk != text:
        on_disk = parse(disk, file)
        if not on_disk.problems and doc_from_spec(on_disk) == doc:
            spec = on_disk
    refused: list[Problem] = []
    if folder is not None:
        spec, refused = path_problems(spec, folder)
    found: list[Problem] = list(refused)
    try:
        resolve(spec)
    except GraphError as exc:
        found += exc.problems
    problems = [p.to_json() | {"text": str(p)} for p in found]
    return {
        "valid": not problems,
        "problems": problems,
        "text": text,
        # The radar at a glance, from the graph's own parameters.
        "summary": system_summary(spec),
        "keys": key_values(spec),
    }


def read_text(path: Path) -> str:
    """A file's text as the graph reader sees it; bytes that are not UTF-8 show as U+FFFD.

    Such a file opens read-only (the reader names the first bad byte), so the replacement
    characters only ever reach a diff, never a file.
    """
    return path.read_bytes().decode("utf-8", errors="replace") if path.is_file() else ""


def diff(old: str, new: str, path: str) -> str:
    lines = difflib.unified_diff(
        old.splitlines(keepends=True), new.splitlines(keepends=True), f"a/{path}", f"b/{path}"
    )
    return "".join(lines)


def open_graph(folder: Folder, rel: str) -> dict[str, Any]:
    """Everything the page needs to show one graph file."""
    path = folder.resolve(rel)
    text = read_text(path)
    spec = read(path)
    spec.file = rel
    # The reader names the file by the path it was given; the page names it relatively.
    spec.problems = [dataclasses.replace(p, file=rel) for p in spec.problems]
    doc = doc_from_spec(spec)
    # A file the format cannot read fully (not UTF-8, malformed YAML, a bad block entry) would
    # lose the unreadable parts on save: it opens read-only, with the reader's own messages.
    unreadable = [p.to_json() | {"text": str(p)} for p in spec.problems]
    result = (
        check(doc, rel, text, folder)
        if not unreadable
        else {"valid": False, "problems": unreadable}
    )
    return {
        "path": rel,
        "doc": doc,
        "text": text,
        "sha256": sha256(text),
        "canonical": not unreadable and dumps(spec) == text,
        "editable": not unreadable,
        "validation": result,
        "layout": read_layout(path) | {"auto": auto_layout(doc)},
        "run_choices": run_choices(doc),
    }


def auto_layout(doc: Any) -> dict[str, Any]:
    """The automatic layout of a document (the one ``pasim graph`` draws)."""
    from ..graph_export import auto_layout_json, view

    return auto_layout_json(view(spec_from_doc(doc)))


def subsystem(type_name: str) -> str:
    return type_name.split(".", 1)[0] if "." in type_name else type_name


# ---------------------------------------------------------------------------------------------
# Palette and run choices


def palette() -> dict[str, Any]:
    """Every registered block type's interface, grouped by subsystem; broken plugins named."""
    from ..graph_export import HEADER_HEIGHT, NODE_PAD, NODE_WIDTH, ROW_HEIGHT, kind_colors

    blocks = registry.all_blocks()
    faces = []
    for name, cls in blocks.items():
        face = json.loads(json.dumps(cls.interface(name), default=str))
        face["group"] = subsystem(name)
        face["per_chunk"] = cls.runs_per_chunk()
        # The engine's own words for each type, whatever fields the type's JSON carries.
        for side, ports in (("inputs", cls.inputs), ("outputs", cls.outputs)):
            for p in face[side]:
                p["type"]["text"] = ports[p["name"]].type.describe()
        faces.append(face)
    groups: dict[str, list[str]] = {}
    for face in faces:
        groups.setdefault(face["group"], []).append(face["type"])
    # Which inputs each output can feed, by the engine's rule (PortType.mismatch, schemas
    # included): the page marks them while a wire is being drawn.
    feeds: dict[str, list[str]] = {}
    for name, cls in blocks.items():
        for out in cls.outputs.values():
            feeds[f"{name}:{out.name}"] = [
                f"{other}:{inp.name}"
                for other, ocls in blocks.items()
                for inp in ocls.inputs.values()
                if not out.type.mismatch(inp.type)
            ]
    broken = [
        {"type": n, "error": registry.load_error(n) or "failed to load"}
        for n in registry.names()
        if n not in blocks
    ]
    return {
        "blocks": faces,
        "groups": [{"name": g, "types": t} for g, t in sorted(groups.items())],
        "broken": broken,
        "feeds": feeds,
        "kind_colors": kind_colors(),
        # The block geometry the automatic layout assumes; the page draws blocks with it.
        "geometry": {
            "node_width": NODE_WIDTH,
            "header_height": HEADER_HEIGHT,
            "row_height": ROW_HEIGHT,
            "node_pad": NODE_PAD,
        },
    }


def run_choices(doc: Any) -> dict[str, Any]:
    """The fidelity levels a run of this graph can pick, and the scan sector it has.

    Levels are the rungs of the one block that declares a ``fidelity_ladder`` (as ``pasim
    tradeoff`` uses them), or else the ``choices`` of the parameter that the one block
    declaring a fidelity level names (``Block.fidelity_param``, read from the class the
    registry gives, whatever the parameter is called).
    """
    try:
        spec = spec_from_doc(doc)
    except RequestError:
        return {"levels": [], "sector": None, "current": ""}
    classes = {n: registry.get(b.type) for n, b in spec.blocks.items()}
    known = {n: c for n, c in classes.items() if c is not None}
    levels: list[dict[str, Any]] = []
    current = ""
    owners = [n for n, c in known.items() if c.fidelity_ladder]
    leveled = [n for n, c in known.items() if _fidelity_choices(c)]
    if len(owners) == 1:
        name = owners[0]
        cls = known[name]
        keys = list(dict.fromkeys(k for _, p in cls.fidelity_ladder for k in p))
        for label, settings in cls.fidelity_ladder:
            # Every rung sets the same keys, so a level never inherits another's setting.
            full = {k: settings.get(k, cls.params[k].default) for k in keys if k in cls.params}
            levels.append(
                {
                    "label": label,
                    "block": name,
                    "set": {k: format_value(v) for k, v in full.items()},
                }
            )
        # The rung the graph itself runs at, if its values are exactly one rung's.
        own = spec.blocks[name].params
        for level in levels:
            if all(
                format_value(own.get(k, cls.params[k].default)) == v
                for k, v in level["set"].items()
            ):
                current = level["label"]
                break
    elif len(leveled) == 1:
        name = leveled[0]
        param, choices = known[name].fidelity_param, _fidelity_choices(known[name])
        for choice in choices:
            levels.append(
                {"label": str(choice), "block": name, "set": {param: format_value(choice)}}
            )
        own = spec.blocks[name].params.get(param, known[name].params[param].default)
        current = str(own) if own in choices else ""
    sector = None
    scans = [n for n, c in known.items() if c.role == "scan"]
    if len(scans) == 1:
        cls = known[scans[0]]
        vals = []
        for k in ("azimuth_start_deg", "azimuth_stop_deg"):
            if k not in cls.params:
                break
            raw = spec.blocks[scans[0]].params.get(k, cls.params[k].default)
            if isinstance(raw, str) and raw.startswith("$"):
                raw = spec.variables.get(raw[1:])
            vals.append(raw)
        if len(vals) == 2 and all(isinstance(v, (int, float)) for v in vals):
            sector = f"{vals[0]:g}:{vals[1]:g}"
    return {"levels": levels, "sector": sector, "current": current}


def _fidelity_choices(cls: Any) -> tuple[Any, ...]:
    """The levels of the parameter a block class declares as its fidelity level
    (``fidelity_param``); empty when it declares none, or one that is not a parameter with
    choices."""
    param = cls.params.get(cls.fidelity_param) if cls.fidelity_param else None
    return tuple(param.choices or ()) if param is not None else ()


# ---------------------------------------------------------------------------------------------
# Files: atomic writes, the layout side file


def save(
    folder: Folder, rel: Any, doc: Any, base_sha256: Any = None, overwrite: Any = False
) -> dict[str, Any]:
    """Write a document's canonical text to a graph file of the folder.

    Everything is checked before the file is touched. A file changed on disk since the page
    read it (``base_sha256`` differs) is not overwritten unless ``overwrite`` is true, and
    neither is an existing file the page did not open ("save as" onto it).
    """
    path = folder.resolve(rel, must_exist=False)
    _, text = canonical(doc, rel)
    if not path.parent.is_dir():
        raise RequestError(400, f"cannot save {rel!r}: its folder does not exist")
    if overwrite is not True and overwrite is not False:
        raise RequestError(400, "'overwrite' must be true or false")
    if base_sha256 is not None and not isinstance(base_sha256, str):
        raise RequestError(400, "'base_sha256' must be text")
    old = read_text(path)
    if path.exists() and not overwrite:
        if base_sha256 is None:
            raise RequestError(409, f"{rel} exists; save over it only with 'overwrite'")
        if sha256(old) != base_sha256:
            raise RequestError(
                409, f"{rel} changed on disk since it was opened; reload it or save with overwrite"
            )
    changes = diff(old, text, rel)
    if text != old or not path.exists():
        write_atomic(path, text)
    return {"path": rel, "sha256": sha256(text), "text": text, "diff": changes}


def layout_file(graph: Path) -> Path:
    """``generic_radar.yaml`` -> ``generic_radar.layout.json`` beside it."""
    return graph.with_name(graph.stem + LAYOUT_SUFFIX)


def read_layout(graph: Path) -> dict[str, Any]:
    path = layout_file(graph)
    if not path.exists():
        return {"positions": {}, "note": ""}
    try:
        data = json.loads(path.read_text())
        positions = {
            str(k): [float(v[0]), float(v[1])]
            for k, v in data.get("positions", {}).items()
            if isinstance(v, list) and len(v) == 2
        }
        return {"positions": positions, "note": ""}
    except (OSError, ValueError, TypeError, AttributeError) as exc:
        return {"positions": {}, "note": f"{path.name} is unreadable ({exc}); using automatic"}


def write_layout(folder: Folder, rel: Any, positions: Any) -> dict[str, Any]:
    """Save block positions to the side file of a graph (never into the graph file)."""
    graph = folder.resolve(rel)
    positions = mapping(positions, "'positions'")
    clean: dict[str, list[float]] = {}
    for name, xy in positions.items():
        if not BLOCK_NAME.match(name):
            raise RequestError(400, f"'positions': invalid block name {name!r}")
        if (
            not isinstance(xy, list)
            or len(xy) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in xy)
            or not all(math.isfinite(v) and abs(v) < 1e7 for v in xy)
        ):
            raise RequestError(400, f"'positions': block {name!r} needs [x, y], finite numbers")
        clean[name] = [round(float(xy[0]), 1), round(float(xy[1]), 1)]
    text = json.dumps(
        {"format": LAYOUT_FORMAT, "graph": graph.name, "positions": dict(sorted(clean.items()))},
        indent=1,
    )
    path = layout_file(graph)
    write_atomic(path, text + "\n")
    return {"path": folder.rel(path), "positions": clean}
