// The studio page: a graph file drawn as blocks and typed wires (React Flow), edited through
// the engine. The page keeps the graph as a document (see pasim_graph/studio/documents.py);
// every edit goes to the server, which checks it with the engine before the page accepts it,
// and every problem shown is the engine's message.
import {
  Background,
  Controls,
  MiniMap,
  ReactFlow,
  ReactFlowProvider,
  applyEdgeChanges,
  applyNodeChanges,
  useReactFlow,
} from "@xyflow/react";
import { useCallback, useEffect, useMemo, useRef, useState } from "react";
import { api, connText, subsystem } from "./api.js";
import BlockNode from "./BlockNode.jsx";
import { StudioContext } from "./context.js";
import Inspector from "./Inspector.jsx";
import Palette from "./Palette.jsx";
import { Comparison, RunForm, RunList, RunResult } from "./Runs.jsx";
import WireEdge from "./WireEdge.jsx";

const nodeTypes = { block: BlockNode };
const edgeTypes = { wire: WireEdge };
const NO_PROBLEMS = [];
const EMPTY_DOC = { format: "pasim-graph/1", variables: {}, blocks: {}, connections: [] };

function clone(x) {
  return JSON.parse(JSON.stringify(x));
}

// The ports a block shows: its type's declared ports, or (unknown type) those its wires name.
function portsOf(name, block, face, doc) {
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

function resolvePort(ports, port) {
  if (port) return port;
  return ports.length === 1 ? ports[0].name : null;
}

function samePoint(a, b) {
  return a && b && a[0] === b[0] && a[1] === b[1];
}

function Studio() {
  const rf = useReactFlow();
  const [session, setSession] = useState(null);
  const [palette, setPalette] = useState(null);
  const [graphs, setGraphs] = useState([]);
  const [truths, setTruths] = useState([]);
  const [graph, setGraph] = useState(null); // {path, sha256, canonical, editable}
  const [doc, setDoc] = useState(EMPTY_DOC);
  const [validation, setValidation] = useState(null);
  const [auto, setAuto] = useState({ positions: {}, routes: {} });
  const [nodes, setNodes] = useState([]);
  const [edges, setEdges] = useState([]);
  const [selection, setSelection] = useState(null);
  const [swapOptions, setSwapOptions] = useState(null);
  const [swapMessage, setSwapMessage] = useState(null);
  const [notice, setNotice] = useState(null);
  const [tab, setTab] = useState("inspect");
  const [runs, setRuns] = useState([]);
  const [shownRun, setShownRun] = useState(null);
  const [compare, setCompare] = useState([]);
  const [comparison, setComparison] = useState(null);
  const [dock, setDock] = useState("result");
  const [dockOpen, setDockOpen] = useState(false);
  const positions = useRef({});
  const stash = useRef({});
  const validateSeq = useRef(0);
  const history = useRef({ undo: [], redo: [] }); // documents before (and after) each edit

  const faces = useMemo(
    () => Object.fromEntries((palette?.blocks || []).map((b) => [b.type, b])),
    [palette],
  );
  // One array per validation: a fresh [] on every render would re-run the canvas effects
  // that depend on it, for ever.
  const problems = useMemo(() => validation?.problems || NO_PROBLEMS, [validation]);
  const editable = Boolean(graph?.editable);

  const say = useCallback((kind, text, action) => setNotice({ kind, text, action }), []);

  // -- loading -----------------------------------------------------------------------------

  const openGraph = useCallback(
    async (path) => {
      try {
        const g = await api(`graph?path=${encodeURIComponent(path)}`);
        positions.current = { ...g.layout.auto.positions, ...g.layout.positions };
        stash.current = {};
        history.current = { undo: [], redo: [] };
        setAuto(g.layout.auto);
        setGraph({ path: g.path, sha256: g.sha256, canonical: g.canonical, editable: g.editable });
        setDoc(g.doc);
        setValidation({ ...g.validation, diff: "", changed: false, run_choices: g.run_choices });
        setSelection(null);
        setSwapMessage(null);
        setNotice(g.layout.note ? { kind: "warn", text: g.layout.note } : null);
        const url = new URL(window.location.href);
        url.searchParams.set("graph", g.path);
        window.history.replaceState(null, "", url);
        setTimeout(() => rf.fitView({ padding: 0.08 }), 60);
        return true;
      } catch (err) {
        say("error", err.message);
        return false;
      }
    },
    [rf, say],
  );

  useEffect(() => {
    (async () => {
      try {
        const [s, p, t] = await Promise.all([api("session"), api("palette"), api("truths")]);
        setSession(s);
        setPalette(p);
        setGraphs(s.graphs);
        setTruths(t.truths);
        const root = document.documentElement.style;
        for (const [k, v] of Object.entries(p.geometry || {})) root.setProperty(`--${k.replaceAll("_", "-")}`, `${v}px`);
        const wanted = new URLSearchParams(window.location.search).get("graph") || s.first_graph || s.graphs[0];
        // A graph that cannot be opened leaves an empty, usable page (its error is shown).
        if (!wanted || !(await openGraph(wanted)))
          setGraph({ path: "untitled.yaml", sha256: null, canonical: true, editable: true });
      } catch (err) {
        say("error", err.message);
      }
    })();
  }, [openGraph, say]);

  // -- the canvas, from the document -------------------------------------------------------

  useEffect(() => {
    if (!palette) return;
    setNodes((prev) => {
      const old = Object.fromEntries(prev.map((n) => [n.id, n]));
      return Object.entries(doc.blocks).map(([name, block]) => {
        const face = faces[block.type];
        const { inputs, outputs } = portsOf(name, block, face, doc);
        const wiredInputs = doc.connections
          .filter((c) => c.dst === name)
          .map((c) => resolvePort(inputs, c.dst_port));
        const pos = positions.current[name] || old[name]?.position || { x: 0, y: 0 };
        const position = Array.isArray(pos) ? { x: pos[0], y: pos[1] } : pos;
        return {
          ...(old[name] || {}),
          id: name,
          type: "block",
          position,
          selected: selection?.kind === "block" && selection.id === name,
          data: {
            type: block.type,
            known: Boolean(face),
            inputs,
            outputs,
            wiredInputs,
            problems: problems.filter((p) => p.block === name).length,
          },
        };
      });
    });
  }, [doc, faces, palette, problems, selection]);

  useEffect(() => {
    if (!palette) return;
    const colors = palette.kind_colors;
    setEdges(() =>
      doc.connections.map((c) => {
        const text = connText(c);
        const src = doc.blocks[c.src];
        const dst = doc.blocks[c.dst];
        const srcPorts = src ? portsOf(c.src, src, faces[src.type], doc).outputs : [];
        const dstPorts = dst ? portsOf(c.dst, dst, faces[dst.type], doc).inputs : [];
        const sp = resolvePort(srcPorts, c.src_port) || c.src_port || "out";
        const dp = resolvePort(dstPorts, c.dst_port) || c.dst_port || "in";
        const kind = srcPorts.find((p) => p.name === sp)?.type?.kind;
        const unmoved =
          samePoint(positions.current[c.src], auto.positions[c.src]) &&
          samePoint(positions.current[c.dst], auto.positions[c.dst]);
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
      }),
    );
  }, [doc, faces, palette, problems, selection, auto]);

  // -- edits: every one is checked by the engine before the page takes it -------------------

  const commit = useCallback(
    async (next, { record = true } = {}) => {
      const seq = ++validateSeq.current;
      try {
        const v = await api("validate", { path: graph?.path, doc: next });
        if (seq !== validateSeq.current) return true;
        if (record) {
          history.current.undo.push(doc);
          history.current.redo = [];
        }
        setDoc(next);
        setValidation(v);
        return true;
      } catch (err) {
        say("error", err.message);
        return false;
      }
    },
    [graph, doc, say],
  );

  const undo = useCallback(
    async (redo = false) => {
      const [from, to] = redo ? ["redo", "undo"] : ["undo", "redo"];
      const prev = history.current[from].pop();
      if (!prev) return;
      if (await commit(prev, { record: false })) history.current[to].push(doc);
      else history.current[from].push(prev);
    },
    [commit, doc],
  );

  const addBlock = useCallback(
    async (type, at) => {
      const base = subsystem(type).replace(/[^\w-]/g, "_") || "block";
      let name = base;
      for (let i = 2; doc.blocks[name]; i += 1) name = `${base}${i}`;
      const next = clone(doc);
      next.blocks[name] = { type, params: {} };
      const centre = rf.screenToFlowPosition({ x: window.innerWidth / 2, y: window.innerHeight / 3 });
      const p = at || centre;
      positions.current[name] = [Math.round(p.x), Math.round(p.y)];
      if (await commit(next)) setSelection({ kind: "block", id: name });
    },
    [doc, commit, rf],
  );

  const deleteBlocks = useCallback(
    (names) => {
      const next = clone(doc);
      for (const n of names) delete next.blocks[n];
      next.connections = next.connections.filter((c) => !names.includes(c.src) && !names.includes(c.dst));
      setSelection(null);
      return commit(next);
    },
    [doc, commit],
  );

  const deleteWires = useCallback(
    (texts) => {
      const next = clone(doc);
      next.connections = next.connections.filter((c) => !texts.includes(connText(c)));
      setSelection(null);
      return commit(next);
    },
    [doc, commit],
  );

  const setParam = useCallback(
    (block, param, text) => {
      const next = clone(doc);
      const params = next.blocks[block].params || {};
      if (text === "" || text === null) delete params[param];
      else params[param] = text;
      next.blocks[block].params = params;
      return commit(next);
    },
    [doc, commit],
  );

  const setVariable = useCallback(
    (name, text) => {
      const next = clone(doc);
      next.variables = next.variables || {};
      if (text === null) delete next.variables[name];
      else next.variables[name] = text;
      return commit(next);
    },
    [doc, commit],
  );

  const renameBlock = useCallback(
    async (old, name, undo) => {
      if (doc.blocks[name]) {
        say("error", `there is already a block named '${name}'`);
        undo();
        return;
      }
      const next = clone(doc);
      next.blocks = Object.fromEntries(Object.entries(next.blocks).map(([k, v]) => [k === old ? name : k, v]));
      for (const c of next.connections) {
        if (c.src === old) c.src = name;
        if (c.dst === old) c.dst = name;
      }
      if (await commit(next)) {
        positions.current[name] = positions.current[old];
        stash.current[name] = stash.current[old];
        setSelection({ kind: "block", id: name });
        say("info", `Renamed '${old}' to '${name}'. A block's random numbers follow its name: runs change.`);
      } else undo();
    },
    [doc, commit, say],
  );

  const swap = useCallback(
    async (type) => {
      const block = selection?.id;
      if (!block) return;
      setSwapMessage(null);
      try {
        const res = await api("swap", { path: graph.path, doc, block, type, stash: stash.current[block] || {} });
        if (!(await commit(res.doc))) return;
        stash.current[block] = { ...(stash.current[block] || {}), ...res.dropped };
        for (const k of Object.keys(res.restored)) delete stash.current[block][k];
        const parts = [`Swapped '${block}' to ${type}.`];
        const dropped = Object.entries(res.dropped);
        if (dropped.length)
          parts.push(
            `Dropped ${dropped.map(([k, v]) => `${k} = ${v}`).join(", ")}: ${type} has no such parameter (kept, and restored if you swap back).`,
          );
        const restored = Object.entries(res.restored);
        if (restored.length) parts.push(`Restored ${restored.map(([k, v]) => `${k} = ${v}`).join(", ")}.`);
        setSwapMessage({ ok: true, text: parts.join(" ") });
      } catch (err) {
        setSwapMessage({ ok: false, text: err.message });
      }
    },
    [selection, graph, doc, commit],
  );

  // The types a selected block could become, with the reasons the others cannot.
  useEffect(() => {
    setSwapOptions(null);
    if (selection?.kind !== "block" || !doc.blocks[selection.id]) return;
    let live = true;
    api("swap-options", { doc, block: selection.id })
      .then((o) => live && setSwapOptions(o))
      .catch((err) => live && say("error", err.message));
    return () => {
      live = false;
    };
  }, [selection, doc, say]);

  useEffect(() => setSwapMessage(null), [selection?.id]);

  // -- canvas events -----------------------------------------------------------------------

  const onNodesChange = useCallback((changes) => {
    // Removal goes through the document (onDelete); everything else is the canvas's own.
    const kept = changes.filter((c) => c.type !== "remove" && c.type !== "select");
    for (const c of kept) if (c.type === "position" && c.position) positions.current[c.id] = [c.position.x, c.position.y];
    setNodes((ns) => applyNodeChanges(kept, ns));
  }, []);

  const onEdgesChange = useCallback((changes) => {
    setEdges((es) => applyEdgeChanges(changes.filter((c) => c.type !== "remove" && c.type !== "select"), es));
  }, []);

  const saveLayout = useCallback(async () => {
    if (!graph?.sha256) return; // a graph not yet on disk gets its layout file when saved
    try {
      const rounded = Object.fromEntries(
        Object.entries(positions.current)
          .filter(([k]) => doc.blocks[k])
          .map(([k, p]) => [k, Array.isArray(p) ? p : [p.x, p.y]]),
      );
      await api("layout", { path: graph.path, positions: rounded });
    } catch (err) {
      say("error", `layout not saved: ${err.message}`);
    }
  }, [graph, doc, say]);

  const onNodeDragStop = useCallback(() => {
    setAuto((a) => ({ ...a })); // re-evaluate which wires still follow their lanes
    saveLayout();
  }, [saveLayout]);

  const autoLayout = useCallback(async () => {
    try {
      const a = await api("layout/auto", { doc });
      positions.current = { ...a.positions };
      setAuto(a);
      setNodes((ns) => ns.map((n) => ({ ...n, position: { x: a.positions[n.id][0], y: a.positions[n.id][1] } })));
      setTimeout(() => rf.fitView({ padding: 0.08 }), 60);
      saveLayout();
    } catch (err) {
      say("error", err.message);
    }
  }, [doc, rf, saveLayout, say]);

  const onConnect = useCallback(
    (p) => {
      const c = { src: p.source, src_port: p.sourceHandle, dst: p.target, dst_port: p.targetHandle };
      if (doc.connections.some((x) => connText(x) === connText(c))) return;
      const next = clone(doc);
      next.connections.push(c);
      commit(next);
    },
    [doc, commit],
  );

  const onDelete = useCallback(
    async ({ nodes: ns, edges: es }) => {
      if (!editable) return;
      if (ns.length) await deleteBlocks(ns.map((n) => n.id));
      else if (es.length) await deleteWires(es.map((e) => e.id));
    },
    [editable, deleteBlocks, deleteWires],
  );

  // -- files ------------------------------------------------------------------------------

  const save = useCallback(
    async (overwrite = false, asPath = null) => {
      const path = asPath || graph.path;
      try {
        const res = await api("save", {
          path,
          doc,
          base_sha256: asPath ? null : graph.sha256,
          overwrite,
        });
        setGraph({ ...graph, path, sha256: res.sha256, canonical: true });
        setValidation((v) => ({ ...v, ...res.validation, diff: "", changed: false }));
        if (asPath) setGraphs((await api("graphs")).graphs);
        say("ok", res.diff ? `Saved ${path}.` : `Saved ${path} (no change).`);
        if (asPath || !graph.sha256) {
          const rounded = Object.fromEntries(
            Object.entries(positions.current).filter(([k]) => doc.blocks[k]).map(([k, p]) => [k, Array.isArray(p) ? p : [p.x, p.y]]),
          );
          await api("layout", { path, positions: rounded });
        }
      } catch (err) {
        if (err.status === 409) say("warn", err.message, { label: "Save over it", run: () => save(true, asPath) });
        else say("error", err.message);
      }
    },
    [graph, doc, say],
  );

  const saveAs = useCallback(() => {
    const path = window.prompt("Save as (a .yaml file in the served folder):", graph?.path || "untitled.yaml");
    if (path) save(false, path);
  }, [graph, save]);

  const newGraph = useCallback(() => {
    if (validation?.changed && !window.confirm("Discard the unsaved changes?")) return;
    const path = window.prompt("New graph file (in the served folder):", "untitled.yaml");
    if (!path) return;
    positions.current = {};
    stash.current = {};
    history.current = { undo: [], redo: [] };
    setGraph({ path, sha256: null, canonical: true, editable: true });
    setAuto({ positions: {}, routes: {} });
    setSelection(null);
    commit(clone(EMPTY_DOC));
  }, [validation, commit]);

  const exportSvg = useCallback(async () => {
    try {
      const pos = Object.fromEntries(nodes.map((n) => [n.id, [n.position.x, n.position.y]]));
      const res = await api("export", { path: graph.path, doc, format: "svg", positions: pos });
      const url = URL.createObjectURL(new Blob([res.text], { type: "image/svg+xml" }));
      const a = document.createElement("a");
      a.href = url;
      a.download = graph.path.replace(/\.ya?ml$/, "").split("/").pop() + ".svg";
      a.click();
      URL.revokeObjectURL(url);
    } catch (err) {
      say("error", err.message);
    }
  }, [nodes, graph, doc, say]);

  useEffect(() => {
    const onKey = (e) => {
      if (!(e.ctrlKey || e.metaKey)) return;
      const inField = ["INPUT", "SELECT", "TEXTAREA"].includes(document.activeElement?.tagName);
      if (e.key === "s") {
        e.preventDefault();
        if (editable) save();
      } else if ((e.key === "z" || e.key === "Z" || e.key === "y") && !inField && editable) {
        // In a text field, the field's own undo; on the canvas, the graph's.
        e.preventDefault();
        undo(e.key === "y" || e.shiftKey);
      }
    };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  }, [save, undo, editable]);

  // -- runs -------------------------------------------------------------------------------

  const startRun = useCallback(
    async (opts) => {
      try {
        const run = await api("runs", { path: graph.path, doc, ...opts });
        setRuns((rs) => [...rs, run]);
        setShownRun(run.id);
        setDock("result");
        setDockOpen(true);
      } catch (err) {
        say("error", err.message);
      }
    },
    [graph, doc, say],
  );

  const active = runs.filter((r) => ["starting", "running", "drawing"].includes(r.state));
  useEffect(() => {
    if (!active.length) return;
    const timer = setInterval(async () => {
      for (const r of active) {
        try {
          const fresh = await api(`runs/${r.id}`);
          setRuns((rs) => rs.map((x) => (x.id === fresh.id ? fresh : x)));
        } catch (err) {
          say("error", err.message);
        }
      }
    }, 400);
    return () => clearInterval(timer);
  }, [active.map((r) => r.id).join(","), say]); // eslint-disable-line react-hooks/exhaustive-deps

  const cancelRun = useCallback(
    async (id) => {
      try {
        const fresh = await api(`runs/${id}/cancel`, {});
        setRuns((rs) => rs.map((x) => (x.id === fresh.id ? fresh : x)));
      } catch (err) {
        say("error", err.message);
      }
    },
    [say],
  );

  const toggleCompare = useCallback((id) => {
    setCompare((c) => (c.includes(id) ? c.filter((x) => x !== id) : [...c, id].slice(-2)));
  }, []);

  useEffect(() => {
    if (compare.length !== 2) {
      setComparison(null);
      return;
    }
    const [a, b] = [...compare].sort((x, y) => Number(x) - Number(y));
    api(`compare?a=${a}&b=${b}`)
      .then((c) => {
        setComparison(c);
        setDock("compare");
        setDockOpen(true);
      })
      .catch((err) => say("error", err.message));
  }, [compare, say]);

  const studioContext = useMemo(
    () => ({ colors: palette?.kind_colors || {}, feeds: palette?.feeds || {} }),
    [palette],
  );

  // The canvas changes size when the dock opens or closes: keep the whole graph in view.
  useEffect(() => {
    const timer = setTimeout(() => rf.fitView({ padding: 0.08 }), 80);
    return () => clearTimeout(timer);
  }, [dockOpen, rf]);

  if (!palette || !graph) {
    return (
      <div className="loading">
        {notice ? <div className={`message ${notice.kind}`}>{notice.text}</div> : "Loading the studio…"}
      </div>
    );
  }

  const shown = runs.find((r) => r.id === shownRun);
  const running = runs.some((r) => r.state === "running" || r.state === "starting");

  return (
    <StudioContext.Provider value={studioContext}>
      <div className={`app${dockOpen ? " dock-open" : ""}`}>
        <header className="topbar">
          <div className="brand">PASIM-graph studio</div>
          <select
            value={graphs.includes(graph.path) ? graph.path : ""}
            onChange={(e) => {
              if (validation?.changed && !window.confirm("Discard the unsaved changes?")) return;
              openGraph(e.target.value);
            }}
            data-testid="graph-select"
            aria-label="open a graph"
          >
            {!graphs.includes(graph.path) && <option value="">{graph.path} (new)</option>}
            {graphs.map((g) => (
              <option key={g} value={g}>
                {g}
              </option>
            ))}
          </select>
          <button type="button" onClick={newGraph}>New</button>
          <button
            type="button"
            onClick={() => undo(false)}
            disabled={!editable || !history.current.undo.length}
            title="undo the last edit (Ctrl+Z)"
            data-testid="undo"
          >
            Undo
          </button>
          <button
            type="button"
            onClick={() => undo(true)}
            disabled={!editable || !history.current.redo.length}
            title="redo (Ctrl+Shift+Z)"
          >
            Redo
          </button>
          <button type="button" className="primary" onClick={() => save()} disabled={!editable} data-testid="save-button">
            Save
          </button>
          <button type="button" onClick={saveAs} disabled={!editable}>Save as…</button>
          <button type="button" onClick={autoLayout} data-testid="auto-layout">Auto layout</button>
          <button type="button" onClick={exportSvg}>SVG</button>
          <span className={`status ${validation?.valid ? "ok" : "bad"}`} data-testid="status">
            {validation?.valid ? "valid" : `${problems.length} problem${problems.length === 1 ? "" : "s"}`}
          </span>
          {validation?.changed && <span className="status unsaved" data-testid="unsaved">unsaved changes</span>}
          {notice && (
            <span className={`notice ${notice.kind}`} data-testid="notice">
              {notice.text}
              {notice.action && (
                <button type="button" onClick={() => { setNotice(null); notice.action.run(); }}>
                  {notice.action.label}
                </button>
              )}
              <button type="button" className="link" onClick={() => setNotice(null)} aria-label="dismiss">
                ×
              </button>
            </span>
          )}
        </header>
        <aside className="left">
          <Palette palette={palette} onAdd={(t) => addBlock(t)} editable={editable} />
        </aside>
        <main
          className="canvas"
          onDragOver={(e) => {
            e.preventDefault();
            e.dataTransfer.dropEffect = "copy";
          }}
          onDrop={(e) => {
            e.preventDefault();
            const type = e.dataTransfer.getData("application/x-pasim-block");
            if (type && editable) addBlock(type, rf.screenToFlowPosition({ x: e.clientX, y: e.clientY }));
          }}
        >
          <ReactFlow
            nodes={nodes}
            edges={edges}
            nodeTypes={nodeTypes}
            edgeTypes={edgeTypes}
            onNodesChange={onNodesChange}
            onEdgesChange={onEdgesChange}
            onNodeDragStop={onNodeDragStop}
            onConnect={onConnect}
            onDelete={onDelete}
            onNodeClick={(_, n) => {
              setSelection({ kind: "block", id: n.id });
              setTab("inspect");
            }}
            onEdgeClick={(_, e) => {
              setSelection({ kind: "wire", id: e.id });
              setTab("inspect");
            }}
            onPaneClick={() => setSelection(null)}
            nodesConnectable={editable}
            deleteKeyCode={editable ? ["Delete", "Backspace"] : null}
            minZoom={0.1}
            fitView
            proOptions={{ hideAttribution: true }}
          >
            <Background gap={20} size={1} />
            <MiniMap pannable zoomable nodeStrokeWidth={3} />
            <Controls showInteractive={false} />
          </ReactFlow>
        </main>
        <aside className="right">
          <nav className="tabs">
            {[
              ["inspect", "Inspector"],
              ["problems", `Problems (${problems.length})`],
              ["changes", validation?.changed ? "Changes •" : "Changes"],
              ["run", running ? "Run •" : "Run"],
            ].map(([k, label]) => (
              <button
                type="button"
                key={k}
                className={tab === k ? "active" : ""}
                onClick={() => setTab(k)}
                data-testid={`tab-${k}`}
              >
                {label}
              </button>
            ))}
          </nav>
          <div className="tab-body">
            {tab === "inspect" && (
              <Inspector
                selection={selection}
                doc={doc}
                graph={graph}
                faces={faces}
                problems={problems}
                validation={validation}
                colors={palette.kind_colors}
                options={swapOptions}
                swapMessage={swapMessage}
                editable={editable}
                onSwap={swap}
                onParam={setParam}
                onVariable={setVariable}
                onRename={renameBlock}
                onDelete={(n) => deleteBlocks([n])}
                onDeleteWire={(t) => deleteWires([t])}
              />
            )}
            {tab === "problems" && (
              <div className="problems" data-testid="problems">
                {!problems.length && <div className="message ok">The engine finds no problem in this graph.</div>}
                {problems.map((p) => (
                  <button
                    type="button"
                    key={p.text}
                    className="problem clickable"
                    onClick={() => {
                      if (p.block && doc.blocks[p.block]) {
                        setSelection({ kind: "block", id: p.block });
                        setTab("inspect");
                      }
                    }}
                  >
                    {p.text}
                  </button>
                ))}
              </div>
            )}
            {tab === "changes" && (
              <div data-testid="changes">
                <div className="muted">What saving writes to {graph.path}:</div>
                <pre className="diff">{validation?.diff || "nothing: the file on disk is the same"}</pre>
              </div>
            )}
            {tab === "run" && (
              <div>
                <RunForm
                  choices={validation?.run_choices}
                  truths={truths}
                  onRun={startRun}
                  running={running}
                  graphValid={validation?.valid}
                />
                <div className="panel-subtitle">Runs</div>
                <RunList
                  runs={runs}
                  shown={shownRun}
                  compare={compare}
                  onShow={(id) => {
                    setShownRun(id);
                    setDock("result");
                    setDockOpen(true);
                  }}
                  onCompare={toggleCompare}
                  onCancel={cancelRun}
                />
                {compare.length === 1 && <div className="muted">Tick a second run to compare.</div>}
                <div className="muted runs-dir">
                  Stores: {session?.runs_dir} {session?.runs_kept ? "" : "(deleted when the studio stops)"}
                </div>
              </div>
            )}
          </div>
        </aside>
        <section className="dock" data-testid="dock">
          <nav className="tabs">
            <button type="button" className={dock === "result" ? "active" : ""} onClick={() => { setDock("result"); setDockOpen(true); }}>
              Result{shown ? `: ${shown.label}` : ""}
            </button>
            <button
              type="button"
              className={dock === "compare" ? "active" : ""}
              disabled={!comparison}
              onClick={() => { setDock("compare"); setDockOpen(true); }}
              data-testid="dock-compare"
            >
              Compare{comparison ? ` ${comparison.a.id} ↔ ${comparison.b.id}` : " (tick two runs)"}
            </button>
            <button type="button" className="link dock-toggle" onClick={() => setDockOpen(!dockOpen)}>
              {dockOpen ? "hide ▾" : "show ▴"}
            </button>
          </nav>
          {dockOpen && (
            <div className="dock-body">
              {dock === "result" && <RunResult run={shown} />}
              {dock === "compare" && <Comparison data={comparison} />}
            </div>
          )}
        </section>
      </div>
    </StudioContext.Provider>
  );
}

export default function App() {
  return (
    <ReactFlowProvider>
      <Studio />
    </ReactFlowProvider>
  );
}
