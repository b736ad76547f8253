// The canvas's pure helpers: blocks and wires from the document, the first view, copy and
// paste.
import { connText } from "./api.js";

// The ports a block shows: its type's declared ports, or (unknown type) those its wires name.
export function portsOf(name, block, face, doc) {
  if (face) return { inputs: face.inputs, outputs: face.outputs };
  const inputs = [];
  const outputs = [];
  for (const c of doc.connections) {
    if (c.dst === name && !inputs.some((p) => p.name === (c.dst_port || "in")))
      inputs.push({ name: c.dst_port || "in", type: null, required: true });
    if (c.src === name && !outputs.some((p) => p.name === (c.src_port || "out")))
      outputs.push({ name: c.src_port || "out", type: null });
  }
  return { inputs, outputs };
}

export function resolvePort(ports, port) {
  if (port) return port;
  return ports.length === 1 ? ports[0].name : null;
}

// Block titles are 13 px; below this zoom they read smaller than 11 px.
export const MIN_LEGIBLE_ZOOM = 11 / 13 + 0.01;

export function samePoint(a, b) {
  return a && b && a[0] === b[0] && a[1] === b[1];
}

// The whole graph if its titles stay legible (>= 11 px), else as much of it as fits at that
// zoom, from its left end (where the signal starts); the minimap shows the rest.
export function legibleViewport(nodes, width, height, top = 0, pad = 30) {
  if (!nodes.length) return null;
  const x0 = Math.min(...nodes.map((n) => n.position.x));
  const y0 = Math.min(...nodes.map((n) => n.position.y));
  const x1 = Math.max(...nodes.map((n) => n.position.x + (n.measured?.width || 210)));
  const y1 = Math.max(...nodes.map((n) => n.position.y + (n.measured?.height || 100)));
  const room = height - top - pad;
  const fit = Math.min((width - 2 * pad) / (x1 - x0), room / (y1 - y0), 1.2);
  const zoom = Math.max(fit, MIN_LEGIBLE_ZOOM);
  const x = fit >= MIN_LEGIBLE_ZOOM ? (width - (x1 - x0) * zoom) / 2 - x0 * zoom : pad - x0 * zoom;
  const y = (y1 - y0) * zoom <= room ? top + (room - (y1 - y0) * zoom) / 2 - y0 * zoom : top - y0 * zoom;
  return { x, y, zoom };
}

// A copy of blocks: their parameters, the wires whose both ends are copied, their places.
export function copyOf(doc, names, positions) {
  return {
    blocks: Object.fromEntries(names.map((n) => [n, JSON.parse(JSON.stringify(doc.blocks[n]))])),
    wires: doc.connections.filter((c) => names.includes(c.src) && names.includes(c.dst)),
    positions: Object.fromEntries(names.map((n) => [n, positions[n] || [0, 0]])),
  };
}

// The document with a copy pasted in: fresh names (hpa -> hpa2), the copied wires between
// them, each block ``offset`` right and down of its original. Returns {next, renamed, placed}.
export function pasteInto(doc, clip, offset = 40) {
  const next = JSON.parse(JSON.stringify(doc));
  const renamed = {};
  const placed = {};
  for (const [name, block] of Object.entries(clip.blocks)) {
    const base = name.replace(/\d+$/, "") || "block";
    let fresh = base;
    for (let i = 2; next.blocks[fresh]; i += 1) fresh = `${base}${i}`;
    renamed[name] = fresh;
    next.blocks[fresh] = JSON.parse(JSON.stringify(block));
    const p = clip.positions?.[name] || [0, 0];
    placed[fresh] = [p[0] + offset, p[1] + offset];
  }
  for (const c of clip.wires || []) next.connections.push({ ...c, src: renamed[c.src], dst: renamed[c.dst] });
  return { next, renamed, placed };
}

// The canvas's blocks for a document; each keeps what the canvas knows of it (its measured
// size, whether the user selected it) unless ``forced`` names the blocks to select.
export function blockNodes({ doc, faces, problems, keys, prev, forced, positions }) {
  const old = Object.fromEntries(prev.map((n) => [n.id, n]));
  return Object.entries(doc.blocks).map(([name, block]) => {
    const face = faces[block.type];
    const { inputs, outputs } = portsOf(name, block, face, doc);
    const wiredInputs = doc.connections.filter((c) => c.dst === name).map((c) => resolvePort(inputs, c.dst_port));
    const pos = positions[name] || old[name]?.position || { x: 0, y: 0 };
    const position = Array.isArray(pos) ? { x: pos[0], y: pos[1] } : pos;
    return {
      ...(old[name] || {}),
      id: name,
      type: "block",
      position,
      selected: forced ? forced.includes(name) : Boolean(old[name]?.selected),
      data: {
        type: block.type,
        keys: keys[name] || [],
        known: Boolean(face),
        inputs,
        outputs,
        wiredInputs,
        problems: problems.filter((p) => p.block === name).length,
      },
    };
  });
}

// The canvas's wires: coloured by the kind of signal, on their automatic lane while both
// ends stay where the layout put them, red when the engine names them in a problem.
export function wireEdges({ doc, faces, problems, selection, auto, colors, positions }) {
  return doc.connections.map((c) => {
    const text = connText(c);
    const src = doc.blocks[c.src];
    const dst = doc.blocks[c.dst];
    const srcPorts = src ? portsOf(c.src, src, faces[src.type], doc).outputs : [];
    const dstPorts = dst ? portsOf(c.dst, dst, faces[dst.type], doc).inputs : [];
    const sp = resolvePort(srcPorts, c.src_port) || c.src_port || "out";
    const dp = resolvePort(dstPorts, c.dst_port) || c.dst_port || "in";
    const kind = srcPorts.find((p) => p.name === sp)?.type?.kind;
    const unmoved = samePoint(positions[c.src], auto.positions[c.src]) && samePoint(positions[c.dst], auto.positions[c.dst]);
    const problem = problems.some((p) => p.item.includes(`'${text}'`) || p.message.includes(`'${text}'`));
    return {
      id: text,
      source: c.src,
      sourceHandle: sp,
      target: c.dst,
      targetHandle: dp,
      type: "wire",
      selected: selection?.kind === "wire" && selection.id === text,
      data: { color: colors[kind], route: unmoved ? auto.routes[text] : null, problem },
    };
  });
}
