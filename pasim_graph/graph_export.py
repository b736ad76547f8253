"""A graph as a picture: blocks and typed wires, laid out in layers, as SVG, DOT or Mermaid.

``pasim graph GRAPH --format svg|dot|mermaid`` prints one of these for docs and reviews, and
the studio lays its canvas out with the same :func:`layout`, so the page and the exported
picture agree. Everything here is read from the graph file and the registered interfaces
(``Block.interface()``); nothing is built or run. The functions tolerate a graph that does
not validate (an unknown type is drawn with the ports its wires name), because the studio
draws graphs while they are being edited.
"""

from __future__ import annotations

import hashlib
import html
import itertools
from dataclasses import dataclass, field
from typing import Any

import networkx as nx

from . import registry
from .graphfile import Endpoint, GraphSpec

#: Geometry shared with the studio's block nodes (its CSS uses the same numbers), so that the
#: automatic layout leaves room for every port row.
NODE_WIDTH = 210
HEADER_HEIGHT = 44
ROW_HEIGHT = 20
NODE_PAD = 10
GAP_X = 70
GAP_Y = 36

# Distinct on white and, as far as 16 colours can be, for colour-blind readers (Okabe-Ito
# first, then Tol's muted scheme).
_PALETTE = (
    "#0072B2",
    "#D55E00",
    "#009E73",
    "#CC79A7",
    "#E69F00",
    "#56B4E9",
    "#882255",
    "#332288",
    "#117733",
    "#999933",
    "#AA4499",
    "#44AA99",
    "#8C564B",
    "#E6194B",
    "#6A3D9A",
    "#7F7F7F",
)


def kind_colors() -> dict[str, str]:
    """A colour for every signal kind the registered blocks use (the same everywhere).

    Kinds are coloured in name order, so that the library's kinds get distinct colours; a
    kind beyond the palette, or one no registered block has, falls back to a hash.
    """
    kinds: set[str] = set()
    for cls in registry.all_blocks().values():
        kinds.update(p.type.kind for p in cls.inputs.values())
        kinds.update(p.type.kind for p in cls.outputs.values())
    ordered = sorted(kinds)
    return {k: _PALETTE[i] if i < len(_PALETTE) else kind_color(k) for i, k in enumerate(ordered)}


def kind_color(kind: str, colors: dict[str, str] | None = None) -> str:
    """The colour of one signal kind (grey when unknown)."""
    if not kind:
        return "#888888"
    if colors and kind in colors:
        return colors[kind]
    return _PALETTE[hashlib.sha256(kind.encode()).digest()[0] % len(_PALETTE)]


@dataclass
class PortView:
    name: str
    type: dict[str, Any] | None  # the port type's JSON; None when the block type is unknown
    required: bool = True
    text: str = "unknown type"  # the engine's PortType.describe()

    @property
    def kind(self) -> str:
        return str(self.type.get("kind", "")) if self.type else ""


@dataclass
class NodeView:
    name: str
    type: str
    known: bool
    inputs: list[PortView] = field(default_factory=list)
    outputs: list[PortView] = field(default_factory=list)

    @property
    def height(self) -> int:
        rows = max(len(self.inputs), len(self.outputs), 1)
        return HEADER_HEIGHT + rows * ROW_HEIGHT + NODE_PAD

    def port_y(self, side: str, port: str | None) -> float:
        """Offset of a port's row centre from the node's top (the middle when unresolved)."""
        ports = self.inputs if side == "in" else self.outputs
        names = [p.name for p in ports]
        if port in names:
            return HEADER_HEIGHT + names.index(port) * ROW_HEIGHT + ROW_HEIGHT / 2
        return self.height / 2


@dataclass
class WireView:
    src: str
    src_port: str | None
    dst: str
    dst_port: str | None
    kind: str
    type_text: str
    conn: str = ""  # the connection as the file writes it (ports left out stay left out)

    @property
    def text(self) -> str:
        a = f"{self.src}.{self.src_port}" if self.src_port else self.src
        b = f"{self.dst}.{self.dst_port}" if self.dst_port else self.dst
        return f"{a} -> {b}"


@dataclass
class GraphView:
    name: str
    nodes: dict[str, NodeView]
    wires: list[WireView]
    colors: dict[str, str] = field(default_factory=dict)  # signal kind -> colour

    def color(self, kind: str) -> str:
        return kind_color(kind, self.colors)


def view(spec: GraphSpec, name: str = "graph") -> GraphView:
    """What to draw: every block with its declared ports, every wire with its type.

    Parameters
    ----------
    spec : GraphSpec
        The graph as read (it need not validate).
    name : str
        The picture's title.

    Returns
    -------
    GraphView
        Blocks (with the ports of their registered interface, or for an unknown type the
        ports its wires name) and wires (ports resolved where the file leaves them out).
    """
    nodes: dict[str, NodeView] = {}
    for block, b in sorted(spec.blocks.items()):
        cls = registry.get(b.type)
        if cls is None:
            nodes[block] = NodeView(block, b.type, False)
            continue
        face = cls.interface(b.type)
        ins, outs = cls.inputs, cls.outputs
        nodes[block] = NodeView(
            block,
            b.type,
            True,
            [
                PortView(p["name"], p["type"], p["required"], ins[p["name"]].type.describe())
                for p in face["inputs"]
            ],
            [
                PortView(p["name"], p["type"], True, outs[p["name"]].type.describe())
                for p in face["outputs"]
            ],
        )
    wires = []
    for c in sorted(spec.connections, key=str):
        if c.src.block not in nodes or c.dst.block not in nodes:
            continue
        src, dst = nodes[c.src.block], nodes[c.dst.block]
        sp = _resolve(src, "out", c.src.port)
        dp = _resolve(dst, "in", c.dst.port)
        port = next((p for p in src.outputs if p.name == sp), None)
        wires.append(
            WireView(
                src.name,
                sp,
                dst.name,
                dp,
                port.kind if port else "",
                port.text if port else "unknown type",
                str(c),
            )
        )
    return GraphView(name, nodes, wires, kind_colors())


def _resolve(node: NodeView, side: str, port: str | None) -> str | None:
    """The port a wire end means: named, or the block's only port on that side."""
    ports = node.inputs if side == "in" else node.outputs
    if port is None:
        return Endpoint(node.name, None).port_in(p.name for p in ports)
    if not node.known and port not in [p.name for p in ports]:
        # An unknown type is drawn with the ports its wires name.
        ports.append(PortView(port, None))
    return port


@dataclass
class Layout:
    """Where everything goes: the top-left corner of each block, and the bends of long wires.

    ``routes`` maps a wire's index in ``GraphView.wires`` to the points it passes between its
    two ports: a wire that spans several layers runs through a lane reserved for it in each
    layer it crosses (wires from one output share their lane), so it never runs under a block.
    """

    positions: dict[str, tuple[float, float]]
    routes: dict[int, list[tuple[float, float]]]


_LANE = 12.0  # height of a lane that a long wire takes through a layer
#: Where a segment attaches to an item: a block's port (side, name) or a lane's centre.
_Where = tuple[str, str | None] | float


def layout(g: GraphView) -> Layout:
    """Lay a graph out left to right along the signal flow (deterministically).

    A small Sugiyama-style layout: layers by longest path from the sources (a source sits
    just left of its first consumer); a lane for each long wire in every layer it crosses;
    the order within a layer and the heights from the barycentres of the wired ports, swept
    back and forth, each block moved towards its wires' other ends without overlapping.
    """
    dag = nx.DiGraph()
    dag.add_nodes_from(sorted(g.nodes))
    for w in g.wires:
        if w.src != w.dst:
            dag.add_edge(w.src, w.dst)
    # A cycle (an invalid graph being edited) is broken at an edge that closes it.
    while not nx.is_directed_acyclic_graph(dag):
        cycle = nx.find_cycle(dag, source=sorted(dag.nodes))
        dag.remove_edge(*cycle[-1][:2])
    layer: dict[str, int] = {}
    for n in nx.lexicographical_topological_sort(dag):
        layer[n] = max((layer[p] + 1 for p in dag.predecessors(n)), default=0)
    for n in sorted(dag.nodes, key=lambda n: -layer[n]):
        if dag.in_degree(n) == 0 and dag.out_degree(n) > 0:
            layer[n] = min(layer[s] for s in dag.successors(n)) - 1

    # Items are blocks and lanes; a segment joins two items in neighbouring layers.
    height = {n: float(node.height) for n, node in g.nodes.items()}
    item_layer = dict(layer)
    segments: list[tuple[str, _Where, str, _Where]] = []
    lanes_of: dict[int, list[str]] = {}
    for i, w in enumerate(g.wires):
        a, b = layer[w.src], layer[w.dst]
        if b <= a:
            continue
        chain = []
        for k in range(a + 1, b):
            lane = f"\x00{w.src}.{w.src_port}\x00{k}"
            item_layer[lane] = k
            height[lane] = _LANE
            chain.append(lane)
        lanes_of[i] = chain
        stops: list[tuple[str, _Where]] = [(w.src, ("out", w.src_port))]
        stops += [(lane, _LANE / 2) for lane in chain]
        stops.append((w.dst, ("in", w.dst_port)))
        for (p, po), (q, qo) in itertools.pairwise(stops):
            seg = (p, po, q, qo)
            if seg not in segments:
                segments.append(seg)

    def offset(item: str, where: _Where) -> float:
        if isinstance(where, tuple):
            return g.nodes[item].port_y(*where)
        return float(where)

    layers: dict[int, list[str]] = {}
    for n in sorted(item_layer, key=lambda n: (item_layer[n], n)):
        layers.setdefault(item_layer[n], []).append(n)
    order = [layers[k] for k in sorted(layers)]
    y: dict[str, float] = {}

    def gap(a: str, b: str) -> float:
        return GAP_Y if a in g.nodes and b in g.nodes else GAP_Y / 3

    def stack(items: list[str], want: dict[str, float]) -> None:
        bottom, prev = None, None
        for n in items:
            low = 0.0 if bottom is None else bottom + gap(prev or n, n)
            y[n] = max(low, want.get(n, low))
            bottom, prev = y[n] + height[n], n

    for items in order:
        stack(items, {})

    def wanted(n: str, forward: bool) -> float | None:
        deltas = []
        for p, po, q, qo in segments:
            if forward and q == n:
                deltas.append(y[p] + offset(p, po) - offset(q, qo))
            elif not forward and p == n:
                deltas.append(y[q] + offset(q, qo) - offset(p, po))
        return sum(deltas) / len(deltas) if deltas else None

    for sweep in range(10):
        forward = sweep % 2 == 0
        for items in order if forward else order[::-1]:
            want = {n: v for n in items if (v := wanted(n, forward)) is not None}
            items.sort(key=lambda n: (want.get(n, y[n]), n))
            stack(items, want)
    low = min(y.values(), default=0.0)
    first = min(item_layer.values(), default=0)

    def x_of(k: int) -> float:
        return float(k - first) * (NODE_WIDTH + GAP_X)

    positions = {n: (x_of(layer[n]), y[n] - low) for n in sorted(g.nodes)}
    routes = {}
    for i, chain in lanes_of.items():
        points = []
        for lane in chain:
            ly = y[lane] - low + _LANE / 2
            points += [(x_of(item_layer[lane]), ly), (x_of(item_layer[lane]) + NODE_WIDTH, ly)]
        if points:
            routes[i] = points
    return Layout(positions, routes)


def auto_layout_json(g: GraphView) -> dict[str, Any]:
    """The layout for the studio: positions by block, bends by connection text."""
    auto = layout(g)
    return {
        "positions": {k: list(v) for k, v in auto.positions.items()},
        "routes": {g.wires[i].conn: [list(p) for p in r] for i, r in auto.routes.items()},
    }


def wire_path(points: list[tuple[float, float]]) -> str:
    """SVG path data through ``points``: curves between layers, straight along lanes.

    The first and last points are the two ports; the points between come in pairs, the two
    ends of a lane (see :class:`Layout`). The studio draws its wires with the same rule.
    """

    def curve(a: tuple[float, float], b: tuple[float, float]) -> str:
        bend = max(30.0, abs(b[0] - a[0]) / 2)
        return f"C{a[0] + bend:.1f},{a[1]:.1f} {b[0] - bend:.1f},{b[1]:.1f} {b[0]:.1f},{b[1]:.1f}"

    out = [f"M{points[0][0]:.1f},{points[0][1]:.1f}"]
    inner = points[1:-1]
    prev = points[0]
    for j in range(0, len(inner), 2):
        out.append(curve(prev, inner[j]))
        out.append(f"L{inner[j + 1][0]:.1f},{inner[j + 1][1]:.1f}")
        prev = inner[j + 1]
    out.append(curve(prev, points[-1]))
    return " ".join(out)


# ---------------------------------------------------------------------------------------------
# Output formats


def to_svg(g: GraphView, positions: dict[str, tuple[float, float]] | None = None) -> str:
    """A standalone SVG: blocks with their ports, wires coloured by signal kind, a legend.

    ``positions`` (top-left corners, e.g. as arranged in the studio) replace the automatic
    layout; wires are then drawn as plain curves.
    """
    auto = layout(g)
    pos = positions or auto.positions
    routes = auto.routes if positions is None else {}
    margin = 20.0
    width = max((pos[n][0] + NODE_WIDTH for n in g.nodes), default=0.0) + 2 * margin
    graph_h = max(
        [pos[n][1] + g.nodes[n].height for n in g.nodes]
        + [p[1] for r in routes.values() for p in r],
        default=0.0,
    )
    kinds = sorted({(w.kind, w.type_text) for w in g.wires if w.kind})
    legend_top = graph_h + 2 * margin
    height = legend_top + 18 * len(kinds) + margin
    e = html.escape
    out = [
        '<svg xmlns="http://www.w3.org/2000/svg" '
        f'width="{width:.0f}" height="{height:.0f}" viewBox="0 0 {width:.0f} {height:.0f}" '
        'font-family="Helvetica, Arial, sans-serif" font-size="11">',
        f"<title>{e(g.name)}</title>",
        f'<rect width="{width:.0f}" height="{height:.0f}" fill="#ffffff"/>',
        f'<g transform="translate({margin:.0f},{margin:.0f})">',
    ]
    for i, w in enumerate(g.wires):
        src, dst = g.nodes[w.src], g.nodes[w.dst]
        start = (pos[w.src][0] + NODE_WIDTH, pos[w.src][1] + src.port_y("out", w.src_port))
        end = (pos[w.dst][0], pos[w.dst][1] + dst.port_y("in", w.dst_port))
        out.append(
            f'<path class="wire" d="{wire_path([start, *routes.get(i, []), end])}" fill="none" '
            f'stroke="{g.color(w.kind)}" stroke-width="2">'
            f"<title>{e(w.text)}: {e(w.type_text)}</title></path>"
        )
    wired_in = {(w.dst, w.dst_port) for w in g.wires}
    for name, node in g.nodes.items():
        x, top = pos[name]
        fill = "#fdecea" if not node.known else "#eef3f8"
        out.append(f'<g class="block" id="block-{e(name)}">')
        out.append(
            f'<rect x="{x:.1f}" y="{top:.1f}" width="{NODE_WIDTH}" height="{node.height}" '
            f'rx="6" fill="#ffffff" stroke="#5b6770" stroke-width="1.2"/>'
        )
        out.append(
            f'<rect x="{x + 1:.1f}" y="{top + 1:.1f}" width="{NODE_WIDTH - 2}" '
            f'height="{HEADER_HEIGHT - 2}" rx="5" fill="{fill}"/>'
            f'<path d="M{x:.1f},{top + HEADER_HEIGHT:.1f} h{NODE_WIDTH}" stroke="#c9d1d8"/>'
        )
        out.append(
            f'<text x="{x + 10:.1f}" y="{top + 18:.1f}" font-size="13" font-weight="bold">'
            f"{e(name)}</text>"
            f'<text x="{x + 10:.1f}" y="{top + 35:.1f}" fill="#44525c">{e(node.type)}'
            f"{'' if node.known else ' (unknown type)'}</text>"
        )
        for side, ports in (("in", node.inputs), ("out", node.outputs)):
            for p in ports:
                py = top + node.port_y(side, p.name)
                cx = x if side == "in" else x + NODE_WIDTH
                colour = g.color(p.kind)
                hollow = side == "in" and p.required and (name, p.name) not in wired_in
                out.append(
                    f'<circle cx="{cx:.1f}" cy="{py:.1f}" r="4.5" '
                    f'fill="{"#ffffff" if hollow else colour}" stroke="{colour}" '
                    f'stroke-width="1.5"><title>{e(p.name)}: {e(p.text)}</title></circle>'
                )
                tx = x + 10 if side == "in" else x + NODE_WIDTH - 10
                anchor = "start" if side == "in" else "end"
                style = "" if p.required or side == "out" else ' font-style="italic"'
                out.append(
                    f'<text x="{tx:.1f}" y="{py + 4:.1f}" text-anchor="{anchor}"{style}>'
                    f"{e(p.name)}</text>"
                )
        out.append("</g>")
    for i, (kind, text) in enumerate(kinds):
        ly = legend_top - margin + 18 * i
        out.append(
            f'<path d="M0,{ly:.1f} h28" stroke="{g.color(kind)}" stroke-width="3"/>'
            f'<text x="36" y="{ly + 4:.1f}">{e(text)}</text>'
        )
    out.append("</g></svg>")
    return "\n".join(out) + "\n"


def to_dot(g: GraphView) -> str:
    """Graphviz DOT: one HTML-label node per block with a port cell per port, wires by port."""

    def q(text: str) -> str:
        return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'

    e = html.escape
    out = [
        f"digraph {q(g.name)} {{",
        "  rankdir=LR;",
        '  node [shape=plaintext fontname="Helvetica" fontsize=10];',
        '  edge [fontname="Helvetica" fontsize=9 penwidth=1.6];',
    ]
    for name, node in g.nodes.items():
        rows = max(len(node.inputs), len(node.outputs), 1)
        cells = []
        for i in range(rows):
            a = node.inputs[i] if i < len(node.inputs) else None
            b = node.outputs[i] if i < len(node.outputs) else None
            left = f'<TD PORT="i_{e(a.name)}" ALIGN="LEFT">{e(a.name)}</TD>' if a else "<TD></TD>"
            right = f'<TD PORT="o_{e(b.name)}" ALIGN="RIGHT">{e(b.name)}</TD>' if b else "<TD></TD>"
            cells.append(f"<TR>{left}{right}</TR>")
        label = (
            '<<TABLE BORDER="1" CELLBORDER="0" CELLSPACING="0" CELLPADDING="3">'
            f'<TR><TD COLSPAN="2" BGCOLOR="#eef3f8"><B>{e(name)}</B><BR/>{e(node.type)}</TD></TR>'
            + "".join(cells)
            + "</TABLE>>"
        )
        out.append(f"  {q(name)} [label={label}];")
    for w in g.wires:
        src = f"{q(w.src)}:{q('o_' + w.src_port)}:e" if w.src_port else q(w.src)
        dst = f"{q(w.dst)}:{q('i_' + w.dst_port)}:w" if w.dst_port else q(w.dst)
        colour = g.color(w.kind)
        out.append(f"  {src} -> {dst} [color={q(colour)} tooltip={q(w.type_text)}];")
    out.append("}")
    return "\n".join(out) + "\n"


def to_mermaid(g: GraphView) -> str:
    """A Mermaid flowchart: blocks as nodes, each wire labelled with its two port names."""

    def label(text: str) -> str:
        # Mermaid quoted labels take HTML entities; a bare quote would end the label.
        return html.escape(text).replace("&quot;", "#quot;").replace("&#x27;", "'")

    ids = {name: f"b{i}" for i, name in enumerate(g.nodes)}
    out = ["flowchart LR"]
    for name, node in g.nodes.items():
        out.append(f'  {ids[name]}["<b>{label(name)}</b><br/>{label(node.type)}"]')
    for w in g.wires:
        ports = f"{w.src_port or '?'} → {w.dst_port or '?'}"
        out.append(f'  {ids[w.src]} -->|"{label(ports)}"| {ids[w.dst]}')
    for i, w in enumerate(g.wires):
        colour = g.color(w.kind)
        out.append(f"  linkStyle {i} stroke:{colour},stroke-width:2px")
    return "\n".join(out) + "\n"


FORMATS = {"svg": to_svg, "dot": to_dot, "mermaid": to_mermaid}
