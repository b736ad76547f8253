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
import { blockNodes, copyOf, legibleViewport, pasteInto, wireEdges } from "./canvas.js";
import { initialPanels, loadEdits, loadView, saveEdits, savePanels, saveView } from "./persist.js";
import { StudioContext } from "./context.js";
import Inspector from "./Inspector.jsx";
import Palette from "./Palette.jsx";
import Dock from "./Dock.jsx";
import { RunForm, RunList } from "./Runs.jsx";
import SidePanel from "./SidePanel.jsx";
import Topbar from "./Topbar.jsx";
import useRuns from "./useRuns.js";
import useShortcuts from "./useShortcuts.js";
import { blockMenuItems, paneMenuItems } from "./menus.js";
import WireEdge from "./WireEdge.jsx";

const nodeTypes = { block: BlockNode };
const edgeTypes = { wire: WireEdge };
const NO_PROBLEMS = [];
const EMPTY_DOC = { format: "pasim-graph/1", variables: {}, blocks: {}, connections: [] };

function clone(x) {
  return JSON.parse(JSON.stringify(x));
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
  const showDock = useCallback((which) => {
    setDock(which);
    setDockOpen(true);
  }, []);
  const { runs, setRuns, shownRun, setShownRun, compare, setCompare, comparison, startRun, cancelRun, toggleCompare, renameRun } =
    useRuns({ graph, doc, say, showDock });

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
    const el = canvasRef.current;
    if (!el) return;
    // Below the summary that sits over the top of the canvas.
    const top = (el.querySelector(".glance")?.offsetHeight || 0) + 16;
    const view = legibleViewport(rf.getNodes(), el.clientWidth, el.clientHeight, top);
    if (view) rf.setViewport(view);
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
    setNodes((prev) => blockNodes({ doc, faces, problems, keys, prev, forced, positions: positions.current }));
  }, [doc, faces, palette, problems, selection, validation]);

  useEffect(() => {
    if (!palette) return;
    const context = { doc, faces, problems, selection, auto, colors: palette.kind_colors, positions: positions.current };
    setEdges(wireEdges(context));
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
      const clip = copyOf(doc, names, positions.current);
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
    async (clip = null) => {
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
      const { next, renamed, placed } = pasteInto(doc, from);
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

  useShortcuts({
    editable,
    save,
    undo,
    duplicateBlocks,
    selectAll,
    pasteBlocks,
    showKeys: () => setShowKeys(true),
    copyBlocks: () => {
      const clip = copyBlocks();
      if (clip) say("info", `Copied ${Object.keys(clip.blocks).join(", ")} (Ctrl+V pastes).`);
    },
  });

  // -- runs -------------------------------------------------------------------------------

  const studioContext = useMemo(
    () => ({ colors: palette?.kind_colors || {}, feeds: palette?.feeds || {} }),
    [palette],
  );

  // The canvas changes size when the dock opens or closes: keep the whole graph in view.
  useEffect(() => {
    const timer = setTimeout(() => fitLegible(), 80);
    return () => clearTimeout(timer);
  }, [dockOpen, panels.leftOpen, panels.rightOpen, fitLegible]);

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

  const openMenu = useCallback((e, label, items) => {
    e.preventDefault();
    setMenu({ x: e.clientX, y: e.clientY, label, items });
  }, []);

  const blockMenu = (e, node) => {
    if (!node.selected) selectBlocks([node.id]);
    const names = node.selected ? picked() : [node.id];
    openMenu(e, `actions for ${names.join(", ")}`, blockMenuItems(names, editable, {
      duplicate: () => pasteBlocks(copyBlocks(names)),
      copy: () => copyBlocks(names),
      paste: () => pasteBlocks(),
      swap: () => {
        selectBlocks([node.id]);
        setPanels({ rightOpen: true });
        setTab("inspect");
      },
      remove: () => deleteBlocks(names),
    }));
  };
  const paneMenu = (e) =>
    openMenu(e, "canvas actions", paneMenuItems(editable, {
      paste: () => pasteBlocks(),
      selectAll,
      autoLayout,
      fit: () => rf.fitView({ padding: 0.08 }),
      keys: () => setShowKeys(true),
    }));
  const wireMenu = (e, edge) => {
    setSelection({ kind: "wire", id: edge.id });
    openMenu(e, `actions for the wire ${edge.id}`, [
      { label: "Delete wire", keys: "Delete", run: () => deleteWires([edge.id]), disabled: !editable },
    ]);
  };

  if (!palette || !graph) {
    return (
      <div className="loading">
        {notice ? <div className={`message ${notice.kind}`}>{notice.text}</div> : "Loading the studio…"}
      </div>
    );
  }

  const shown = runs.find((r) => r.id === shownRun);
  const running = runs.some((r) => r.state === "running" || r.state === "starting");

  const inspector = (
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
  );
  const runsPanel = (
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
  );

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
        <Topbar
          graphs={graphs}
          graph={graph}
          validation={validation}
          problems={problems}
          notice={notice}
          editable={editable}
          panels={panels}
          canUndo={history.current.undo.length > 0}
          canRedo={history.current.redo.length > 0}
          on={{ openGraph, newGraph, undo, save, saveAs, autoLayout, exportSvg, setPanels, setNotice, showKeys: () => setShowKeys(true) }}
        />
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
            <MiniMap pannable zoomable nodeStrokeWidth={3} ariaLabel="overview of the whole graph" style={{ width: 160, height: 110 }} />
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
          <SidePanel
            tab={tab}
            setTab={setTab}
            problems={problems}
            validation={validation}
            running={running}
            inspector={inspector}
            doc={doc}
            graph={graph}
            onProblem={(p) => {
              if (p.block && doc.blocks[p.block]) {
                selectBlocks([p.block]);
                setTab("inspect");
              }
            }}
            runs={runsPanel}
          />
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
        <Dock
          dock={dock}
          dockOpen={dockOpen}
          shown={shown}
          comparison={comparison}
          onShow={(which) => {
            setDock(which);
            setDockOpen(true);
          }}
          onToggle={() => setDockOpen(!dockOpen)}
        />
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
