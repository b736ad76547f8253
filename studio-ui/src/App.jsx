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
import { ContextMenu, Glance, Legend, ShortcutsDialog, Splitter, SummaryTable } from "./Chrome.jsx";
import { loadEdits, loadPanels, loadView, saveEdits, savePanels, saveView } from "./persist.js";
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

// Block titles are 13 px; below this zoom they read smaller than 11 px.
const MIN_LEGIBLE_ZOOM = 11 / 13 + 0.01;

function initialPanels() {
  const saved = loadPanels();
  const wide = window.innerWidth;
  return {
    left: saved.left || 220,
    right: saved.right || 390,
    dock: saved.dock || Math.round(window.innerHeight * 0.42),
    leftOpen: saved.leftOpen ?? wide >= 1100,
    rightOpen: saved.rightOpen ?? wide >= 760,
  };
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
  const [panels, setPanelsState] = useState(initialPanels);
  const [menu, setMenu] = useState(null);
  const [showKeys, setShowKeys] = useState(false);
  const [historyTick, setHistoryTick] = useState(0);
  const canvasRef = useRef(null);
  const forceSelect = useRef(null); // blocks to select on the next canvas update
  const clipboard = useRef(null);
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
        let shownDoc = g.doc;
        let checked = { ...g.validation, diff: "", changed: false, run_choices: g.run_choices };
        let note = g.layout.note ? { kind: "warn", text: g.layout.note } : null;
        // This tab's edits and undo steps of the file, kept across a reload, while the file
        // on disk is still the one they were made on.
        const kept = g.editable ? loadEdits(g.path) : null;
        if (kept && kept.sha256 === g.sha256) {
          history.current = { undo: kept.undo || [], redo: kept.redo || [] };
          if (JSON.stringify(kept.doc) !== JSON.stringify(g.doc)) {
            try {
              checked = await api("validate", { path: g.path, doc: kept.doc });
              shownDoc = kept.doc;
              note = { kind: "info", text: `Your unsaved edits of ${g.path} are back (kept by this tab).` };
            } catch {
              history.current = { undo: [], redo: [] };
            }
          }
        }
        setAuto(g.layout.auto);
        setGraph({ path: g.path, sha256: g.sha256, canonical: g.canonical, editable: g.editable });
        setDoc(shownDoc);
        setValidation(checked);
        setSelection(null);
        setSwapMessage(null);
        setNotice(note);
        const url = new URL(window.location.href);
        url.searchParams.set("graph", g.path);
        window.history.replaceState(null, "", url);
        setTimeout(() => fitLegible(), 60);
        return true;
      } catch (err) {
        say("error", err.message);
        return false;
      }
    },
    [say], // eslint-disable-line react-hooks/exhaustive-deps
  );

  useEffect(() => {
    (async () => {
      try {
        const [s, p, t, r] = await Promise.all([api("session"), api("palette"), api("truths"), api("runs")]);
        // The server keeps the session's runs: a reload shows them, and what was on view.
        const view = loadView();
        const ids = r.runs.map((x) => x.id);
        setRuns(r.runs);
        if (ids.includes(view.shownRun)) setShownRun(view.shownRun);
        const done = r.runs.filter((x) => x.state === "done").map((x) => x.id);
        if ((view.compare || []).every((id) => done.includes(id))) setCompare(view.compare || []);
        if (view.tab) setTab(view.tab);
        if (view.dock) setDock(view.dock);
        if (view.dockOpen) setDockOpen(true);
        viewRestored.current = true;
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

  // The whole graph if its titles stay legible (>= 11 px), else as much of it as fits at that
  // zoom, from its left end (where the signal starts); the minimap shows the rest.
  const fitLegible = useCallback(() => {
    const ns = rf.getNodes();
    const el = canvasRef.current;
    if (!ns.length || !el) return;
    const w = el.clientWidth;
    const h = el.clientHeight;
    const xs = ns.map((n) => n.position.x);
    const ys = ns.map((n) => n.position.y);
    const x0 = Math.min(...xs);
    const y0 = Math.min(...ys);
    const x1 = Math.max(...ns.map((n) => n.position.x + (n.measured?.width || 210)));
    const y1 = Math.max(...ns.map((n) => n.position.y + (n.measured?.height || 100)));
    const pad = 30;
    const fit = Math.min((w - 2 * pad) / (x1 - x0), (h - 2 * pad) / (y1 - y0), 1.2);
    const zoom = Math.max(fit, MIN_LEGIBLE_ZOOM);
    const x = fit >= MIN_LEGIBLE_ZOOM ? (w - (x1 - x0) * zoom) / 2 - x0 * zoom : pad - x0 * zoom;
    // Below the summary that sits over the top of the canvas.
    const top = (el.querySelector(".glance")?.offsetHeight || 0) + 16;
    const y = (y1 - y0) * zoom <= h - top - pad ? top + (h - top - pad - (y1 - y0) * zoom) / 2 - y0 * zoom : top - y0 * zoom;
    rf.setViewport({ x, y, zoom });
  }, [rf]);

  // -- what survives a reload -------------------------------------------------------------

  useEffect(() => {
    if (graph?.path && graph.editable) saveEdits(graph.path, { sha256: graph.sha256, doc, ...history.current });
  }, [graph, doc, historyTick]);

  const viewRestored = useRef(false);
  useEffect(() => {
    // Not before the saved view was read back: the first render's defaults would replace it.
    if (viewRestored.current) saveView({ shownRun, compare, tab, dock, dockOpen });
  }, [shownRun, compare, tab, dock, dockOpen]);

  const setPanels = useCallback((change) => {
    setPanelsState((p) => {
      const next = { ...p, ...change };
      savePanels(next);
      return next;
    });
  }, []);

  // Leaving with edits not saved: the browser asks first.
  const unsaved = Boolean(validation?.changed);
  useEffect(() => {
    if (!unsaved) return;
    const warn = (e) => {
      e.preventDefault();
      e.returnValue = "";
    };
    window.addEventListener("beforeunload", warn);
    return () => window.removeEventListener("beforeunload", warn);
  }, [unsaved]);

  // -- the canvas, from the document -------------------------------------------------------

  useEffect(() => {
    if (!palette) return;
    const forced = forceSelect.current;
    forceSelect.current = null;
    const keys = validation?.keys || {};
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
    });
  }, [doc, faces, palette, problems, selection, validation]);

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

  // Select these blocks (and show the one in the inspector): now, and once they exist.
  const selectBlocks = useCallback((names) => {
    forceSelect.current = names;
    setNodes((ns) => ns.map((n) => ({ ...n, selected: names.includes(n.id) })));
    setSelection(names.length === 1 ? { kind: "block", id: names[0] } : null);
  }, []);

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
          setHistoryTick((t) => t + 1);
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
      setHistoryTick((t) => t + 1);
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
      if (await commit(next)) selectBlocks([name]);
    },
    [doc, commit, rf], // eslint-disable-line react-hooks/exhaustive-deps
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

  const picked = useCallback(() => {
    const names = rf.getNodes().filter((n) => n.selected).map((n) => n.id);
    if (!names.length && selection?.kind === "block") names.push(selection.id);
    return names.filter((n) => doc.blocks[n]);
  }, [rf, selection, doc]);

  // Copy: the blocks with their parameters, the wires whose both ends are copied, and where
  // they sit (kept by the browser, so a copy can go to another graph or tab).
  const copyBlocks = useCallback(
    (names = picked()) => {
      if (!names.length) return null;
      const clip = {
        blocks: Object.fromEntries(names.map((n) => [n, clone(doc.blocks[n])])),
        wires: doc.connections.filter((c) => names.includes(c.src) && names.includes(c.dst)),
        positions: Object.fromEntries(names.map((n) => [n, positions.current[n] || [0, 0]])),
      };
      clipboard.current = clip;
      try {
        window.localStorage.setItem("pasim-studio:clipboard", JSON.stringify(clip));
      } catch {
        // the copy stays in this page only
      }
      return clip;
    },
    [doc, picked],
  );

  const pasteBlocks = useCallback(
    async (clip = null, offset = 40) => {
      let from = clip || clipboard.current;
      if (!from) {
        try {
          from = JSON.parse(window.localStorage.getItem("pasim-studio:clipboard") || "null");
        } catch {
          from = null;
        }
      }
      if (!from || !Object.keys(from.blocks || {}).length) {
        say("info", "Nothing to paste: select blocks and copy them first (Ctrl+C).");
        return;
      }
      const next = clone(doc);
      const renamed = {};
      const placed = {};
      for (const [name, block] of Object.entries(from.blocks)) {
        const base = name.replace(/\d+$/, "") || "block";
        let fresh = base;
        for (let i = 2; next.blocks[fresh]; i += 1) fresh = `${base}${i}`;
        renamed[name] = fresh;
        next.blocks[fresh] = clone(block);
        const p = from.positions?.[name] || [0, 0];
        placed[fresh] = [p[0] + offset, p[1] + offset];
      }
      for (const c of from.wires || []) next.connections.push({ ...c, src: renamed[c.src], dst: renamed[c.dst] });
      Object.assign(positions.current, placed);
      if (await commit(next)) {
        const names = Object.values(renamed);
        selectBlocks(names);
        const wires = (from.wires || []).length;
        say("ok", `Pasted ${names.join(", ")}${wires ? ` with ${wires} wire${wires > 1 ? "s" : ""}` : ""}.`);
        saveLayout();
      } else for (const n of Object.keys(placed)) delete positions.current[n];
    },
    [doc, commit, say, selectBlocks], // eslint-disable-line react-hooks/exhaustive-deps
  );

  const duplicateBlocks = useCallback(() => {
    const clip = copyBlocks();
    if (clip) pasteBlocks(clip);
  }, [copyBlocks, pasteBlocks]);

  const selectAll = useCallback(() => selectBlocks(Object.keys(doc.blocks)), [doc, selectBlocks]);

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
    const kept = changes.filter((c) => c.type !== "remove");
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
      setTimeout(() => fitLegible(), 60);
      saveLayout();
    } catch (err) {
      say("error", err.message);
    }
  }, [doc, fitLegible, saveLayout, say]);

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
      const inField = ["INPUT", "SELECT", "TEXTAREA"].includes(document.activeElement?.tagName);
      if (e.key === "?" && !inField && !e.ctrlKey && !e.metaKey) {
        e.preventDefault();
        setShowKeys(true);
        return;
      }
      if (!(e.ctrlKey || e.metaKey)) return;
      const key = e.key.toLowerCase();
      if (!inField && editable && ["c", "v", "d", "a"].includes(key) && !e.shiftKey) {
        // In a text field, the field's own; on the canvas, the graph's.
        if (key === "c" && window.getSelection()?.toString()) return; // copying page text
        e.preventDefault();
        if (key === "c") {
          const clip = copyBlocks();
          if (clip) say("info", `Copied ${Object.keys(clip.blocks).join(", ")} (Ctrl+V pastes).`);
        } else if (key === "v") pasteBlocks();
        else if (key === "d") duplicateBlocks();
        else selectAll();
        return;
      }
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
  }, [save, undo, editable, copyBlocks, pasteBlocks, duplicateBlocks, selectAll, say]);

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
    const timer = setTimeout(() => fitLegible(), 80);
    return () => clearTimeout(timer);
  }, [dockOpen, panels.leftOpen, panels.rightOpen, fitLegible]);

  const renameRun = useCallback(
    async (id, label) => {
      try {
        const fresh = await api(`runs/${id}/label`, { label });
        setRuns((rs) => rs.map((x) => (x.id === fresh.id ? { ...x, label: fresh.label } : x)));
      } catch (err) {
        say("error", err.message);
      }
    },
    [say],
  );

  // The kinds of signal the graph's wires carry, for the legend.
  const wireKinds = useMemo(() => {
    const kinds = new Set();
    for (const c of doc.connections) {
      const face = faces[doc.blocks[c.src]?.type];
      const outs = face?.outputs || [];
      const port = c.src_port || (outs.length === 1 ? outs[0].name : null);
      const kind = outs.find((o) => o.name === port)?.type?.kind;
      if (kind) kinds.add(kind);
    }
    return [...kinds].sort();
  }, [doc, faces]);

  const blockMenu = useCallback(
    (e, node) => {
      e.preventDefault();
      if (!node.selected) selectBlocks([node.id]);
      const names = node.selected ? picked() : [node.id];
      const many = names.length > 1 ? ` (${names.length})` : "";
      setMenu({
        x: e.clientX,
        y: e.clientY,
        label: `actions for ${names.join(", ")}`,
        items: [
          { label: `Duplicate${many}`, keys: "Ctrl+D", run: () => pasteBlocks(copyBlocks(names)), disabled: !editable },
          { label: `Copy${many}`, keys: "Ctrl+C", run: () => copyBlocks(names) },
          { label: "Paste", keys: "Ctrl+V", run: () => pasteBlocks(), disabled: !editable },
          {
            label: "Swap type…",
            run: () => {
              selectBlocks([node.id]);
              setPanels({ rightOpen: true });
              setTab("inspect");
            },
            disabled: names.length > 1,
          },
          { label: `Delete${many}`, keys: "Delete", run: () => deleteBlocks(names), disabled: !editable },
        ],
      });
    },
    [selectBlocks, picked, pasteBlocks, copyBlocks, deleteBlocks, editable, setPanels],
  );

  const paneMenu = useCallback(
    (e) => {
      e.preventDefault();
      setMenu({
        x: e.clientX,
        y: e.clientY,
        label: "canvas actions",
        items: [
          { label: "Paste", keys: "Ctrl+V", run: () => pasteBlocks(), disabled: !editable },
          { label: "Select all", keys: "Ctrl+A", run: selectAll },
          { label: "Auto layout", run: autoLayout },
          { label: "Fit to view", run: () => rf.fitView({ padding: 0.08 }) },
          { label: "Keyboard shortcuts", keys: "?", run: () => setShowKeys(true) },
        ],
      });
    },
    [pasteBlocks, selectAll, autoLayout, rf, editable],
  );

  const wireMenu = useCallback(
    (e, edge) => {
      e.preventDefault();
      setSelection({ kind: "wire", id: edge.id });
      setMenu({
        x: e.clientX,
        y: e.clientY,
        label: `actions for the wire ${edge.id}`,
        items: [{ label: "Delete wire", keys: "Delete", run: () => deleteWires([edge.id]), disabled: !editable }],
      });
    },
    [deleteWires, editable],
  );

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
      <div
        className={`app${dockOpen ? " dock-open" : ""}${panels.leftOpen ? "" : " left-closed"}${panels.rightOpen ? "" : " right-closed"}`}
        style={{
          "--left-width": `${panels.leftOpen ? panels.left : 0}px`,
          "--right-width": `${panels.rightOpen ? panels.right : 0}px`,
          "--dock-height": `${panels.dock}px`,
        }}
      >
        <header className="topbar">
          <button
            type="button"
            className="panel-toggle"
            aria-pressed={panels.leftOpen}
            aria-label={panels.leftOpen ? "hide the block palette" : "show the block palette"}
            title="show or hide the block palette"
            onClick={() => setPanels({ leftOpen: !panels.leftOpen })}
            data-testid="toggle-left"
          >
            ◧
          </button>
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
          <button type="button" onClick={() => setShowKeys(true)} aria-label="keyboard shortcuts" title="keyboard shortcuts (?)">
            ?
          </button>
          <button
            type="button"
            className="panel-toggle"
            aria-pressed={panels.rightOpen}
            aria-label={panels.rightOpen ? "hide the inspector panel" : "show the inspector panel"}
            title="show or hide the inspector, problems, changes and runs"
            onClick={() => setPanels({ rightOpen: !panels.rightOpen })}
            data-testid="toggle-right"
          >
            ◨
          </button>
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
        <aside className="left" hidden={!panels.leftOpen} aria-label="block palette">
          <Palette palette={palette} onAdd={(t) => addBlock(t)} editable={editable} />
        </aside>
        {panels.leftOpen && (
          <Splitter
            label="resize the block palette"
            orientation="vertical"
            value={panels.left}
            min={150}
            max={480}
            onChange={(v) => setPanels({ left: v })}
            className="left-edge"
          />
        )}
        <main
          ref={canvasRef}
          aria-label="the graph"
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
            onNodeContextMenu={blockMenu}
            onPaneContextMenu={paneMenu}
            onEdgeContextMenu={wireMenu}
            onSelectionContextMenu={(e) => {
              const first = rf.getNodes().find((n) => n.selected);
              if (first) blockMenu(e, first);
            }}
            multiSelectionKeyCode={["Shift", "Control", "Meta"]}
            nodesConnectable={editable}
            deleteKeyCode={editable ? ["Delete", "Backspace"] : null}
            minZoom={0.1}
            proOptions={{ hideAttribution: true }}
          >
            <Background gap={20} size={1} />
            <MiniMap pannable zoomable nodeStrokeWidth={3} ariaLabel="overview of the whole graph" />
            <Controls showInteractive={false} />
          </ReactFlow>
          <Glance summary={validation?.summary} />
          <Legend kinds={wireKinds} colors={palette.kind_colors} />
        </main>
        {panels.rightOpen && (
          <Splitter
            label="resize the inspector panel"
            orientation="vertical"
            value={panels.right}
            min={260}
            max={760}
            invert
            onChange={(v) => setPanels({ right: v })}
            className="right-edge"
          />
        )}
        <aside className="right" hidden={!panels.rightOpen} aria-label="inspector, problems, changes and runs">
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
                summaryTable={<SummaryTable summary={validation?.summary} />}
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
                        selectBlocks([p.block]);
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
                  graphPath={graph.path}
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
                  onRename={renameRun}
                />
                {compare.length === 1 && <div className="muted">Tick a second run to compare.</div>}
                <div className="muted runs-dir">
                  Stores: {session?.runs_dir} {session?.runs_kept ? "" : "(deleted when the studio stops)"}
                </div>
              </div>
            )}
          </div>
        </aside>
        {dockOpen && (
          <Splitter
            label="resize the results dock"
            orientation="horizontal"
            value={panels.dock}
            min={120}
            max={Math.max(160, window.innerHeight - 160)}
            invert
            onChange={(v) => setPanels({ dock: v })}
            className="dock-edge"
          />
        )}
        <section className="dock" data-testid="dock" aria-label="results">
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
            <button
              type="button"
              className="link dock-toggle"
              onClick={() => setDockOpen(!dockOpen)}
              aria-expanded={dockOpen}
              aria-label={dockOpen ? "hide the results dock" : "show the results dock"}
              data-testid="dock-toggle"
            >
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
        {menu && <ContextMenu menu={menu} onClose={() => setMenu(null)} />}
        {showKeys && <ShortcutsDialog onClose={() => setShowKeys(false)} />}
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
