"""`pasim graph`: a graph as SVG, Graphviz DOT or Mermaid, and the layout behind the SVG."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import pydot
import pytest

from pasim_graph.graph_export import (
    HEADER_HEIGHT,
    NODE_WIDTH,
    ROW_HEIGHT,
    kind_colors,
    layout,
    to_dot,
    to_mermaid,
    to_svg,
    view,
)
from pasim_graph.graphfile import read

from ..conftest import FIXTURES, GRAPHS, pasim_result

FILES = sorted(GRAPHS.glob("*.yaml"))
SVG = "{http://www.w3.org/2000/svg}"
# pydot's grammar uses pyparsing names that newer pyparsing deprecates; not our concern here.
pytestmark = pytest.mark.filterwarnings("ignore:'setParseAction' deprecated")


def _end(text):
    """``"block":"o_port":e`` -> ``block.port``."""
    block, port = (x.strip('"') for x in text.split(":")[:2])
    return f"{block}.{port[2:]}"


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_svg_draws_every_block_port_and_wire(path):
    spec = read(path)
    g = view(spec, path.stem)
    root = ET.fromstring(to_svg(g))
    blocks = root.findall(f".//{SVG}g[@class='block']")
    assert sorted(b.get("id") for b in blocks) == sorted(f"block-{n}" for n in spec.blocks)
    wires = root.findall(f".//{SVG}path[@class='wire']")
    assert len(wires) == len(spec.connections)
    # Each wire says which connection it is and its full port type.
    titles = sorted(w.find(f"{SVG}title").text.split(": ")[0] for w in wires)
    assert titles == sorted(w.text for w in g.wires)
    for w in wires:
        assert re.search(r"\w+\[\w+; \([\w, ]*\); .+\]$", w.find(f"{SVG}title").text)
    # Every declared port of every block is drawn, named.
    texts = {t.text for t in root.iter(f"{SVG}text")}
    for node in g.nodes.values():
        assert {p.name for p in node.inputs + node.outputs} <= texts


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_layout_has_no_overlap_and_long_wires_avoid_blocks(path):
    g = view(read(path), path.stem)
    lay = layout(g)
    boxes = {n: (*lay.positions[n], NODE_WIDTH, g.nodes[n].height) for n in g.nodes}
    names = sorted(boxes)
    for i, a in enumerate(names):
        ax, ay, aw, ah = boxes[a]
        for b in names[i + 1 :]:
            bx, by, bw, bh = boxes[b]
            overlap = ax < bx + bw and bx < ax + aw and ay < by + bh and by < ay + ah
            assert not overlap, (a, b)
    # Signal flows left to right: every wire of these (acyclic) graphs goes rightwards.
    for w in g.wires:
        assert lay.positions[w.src][0] < lay.positions[w.dst][0], w.text
    # A wire spanning several layers runs in lanes that never pass over a block.
    for i, points in lay.routes.items():
        for x, y in points:
            for n, (bx, by, bw, bh) in boxes.items():
                inside = bx <= x <= bx + bw and by < y < by + bh
                assert not inside, (g.wires[i].text, n, (x, y))
    assert lay == layout(g)  # deterministic


def test_layout_tolerates_cycles_and_unknown_types():
    g = view(read(FIXTURES / "broken" / "cycle.yaml"), "cycle")
    assert set(layout(g).positions) == set(g.nodes)
    g = view(read(FIXTURES / "broken" / "unknown_type.yaml"), "unknown")
    unknown = [n for n in g.nodes.values() if not n.known]
    assert unknown
    assert "(unknown type)" in to_svg(g)


def test_port_rows_match_the_studio_geometry():
    g = view(read(GRAPHS / "generic_radar.yaml"))
    weather = g.nodes["weather"]
    assert [p.name for p in weather.inputs][:2] == ["truth", "beams"]
    assert weather.port_y("in", "truth") == HEADER_HEIGHT + ROW_HEIGHT / 2
    assert weather.port_y("in", "beams") == HEADER_HEIGHT + 1.5 * ROW_HEIGHT


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_dot_parses_with_every_block_and_wire(path):
    spec = read(path)
    g = view(spec, path.stem)
    (graph,) = pydot.graph_from_dot_data(to_dot(g))
    names = {n.get_name().strip('"') for n in graph.get_nodes()} - {"node", "edge"}
    assert names == set(spec.blocks)
    edges = graph.get_edges()
    assert len(edges) == len(spec.connections)
    got = sorted(f"{_end(e.get_source())} -> {_end(e.get_destination())}" for e in edges)
    assert got == sorted(w.text for w in g.wires)
    colours = kind_colors()
    assert {e.get("color").strip('"') for e in edges} <= set(colours.values())


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_mermaid_lists_every_block_and_wire(path):
    spec = read(path)
    text = to_mermaid(view(spec, path.stem))
    lines = text.splitlines()
    assert lines[0] == "flowchart LR"
    nodes = dict(re.findall(r'^  (b\d+)\["<b>([\w-]+)</b><br/>[\w.]+"\]$', text, re.M))
    assert sorted(nodes.values()) == sorted(spec.blocks)
    edges = re.findall(r'^  (b\d+) -->\|"(\w+) → (\w+)"\| (b\d+)$', text, re.M)
    got = sorted(f"{nodes[a]}.{p} -> {nodes[b]}.{q}" for a, p, q, b in edges)
    assert got == sorted(w.text for w in view(spec).wires)
    assert len(re.findall(r"^  linkStyle \d+ stroke:#[0-9A-Fa-f]{6}", text, re.M)) == len(edges)
    # Nothing else: every line is the header, a node, an edge or a link style.
    assert len(lines) == 1 + len(nodes) + 2 * len(edges)


def test_kinds_get_distinct_colours():
    colours = kind_colors()
    assert len(set(colours.values())) == len(colours)


def test_cli_formats_print_and_write(tmp_path, capsys):
    graph = str(GRAPHS / "generic_radar.yaml")
    res = pasim_result(capsys, "graph", graph, "--format", "mermaid")
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("flowchart LR")
    out = tmp_path / "g.svg"
    res = pasim_result(capsys, "graph", graph, "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert ET.parse(out).getroot().tag == f"{SVG}svg"
    res = pasim_result(capsys, "graph", graph, "--format", "dot")
    assert pydot.graph_from_dot_data(res.stdout)


def test_cli_refuses_a_broken_graph_with_the_engine_report(capsys):
    res = pasim_result(capsys, "graph", str(FIXTURES / "broken" / "incompatible.yaml"))
    assert res.returncode == 2
    assert "incompatible types in 'tx.pulse -> antenna.beams'" in res.stderr
    assert not res.stdout
