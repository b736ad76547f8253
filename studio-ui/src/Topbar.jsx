// The bar over the page: panels, the graph to open, the file and edit actions, the verdict.
export default function Topbar({ graphs, graph, validation, problems, notice, editable, panels, canUndo, canRedo, on }) {
  return (
    <header className="topbar">
      <button
        type="button"
        className="panel-toggle"
        aria-pressed={panels.leftOpen}
        aria-label={panels.leftOpen ? "hide the block palette" : "show the block palette"}
        title="show or hide the block palette"
        onClick={() => on.setPanels({ leftOpen: !panels.leftOpen })}
        data-testid="toggle-left"
      >
        ◧
      </button>
      <div className="brand">PASIM-graph studio</div>
      <select
        value={graphs.includes(graph.path) ? graph.path : ""}
        onChange={(e) => {
          if (validation?.changed && !window.confirm("Discard the unsaved changes?")) return;
          on.openGraph(e.target.value);
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
      <button type="button" onClick={on.newGraph}>New</button>
      <button
        type="button"
        onClick={() => on.undo(false)}
        disabled={!editable || !canUndo}
        title="undo the last edit (Ctrl+Z)"
        data-testid="undo"
      >
        Undo
      </button>
      <button
        type="button"
        onClick={() => on.undo(true)}
        disabled={!editable || !canRedo}
        title="redo (Ctrl+Shift+Z)"
      >
        Redo
      </button>
      <button type="button" className="primary" onClick={() => on.save()} disabled={!editable} data-testid="save-button">
        Save
      </button>
      <button type="button" onClick={on.saveAs} disabled={!editable}>Save as…</button>
      <button type="button" onClick={on.autoLayout} data-testid="auto-layout">Auto layout</button>
      <button type="button" onClick={on.exportSvg}>SVG</button>
      <button type="button" onClick={on.showKeys} aria-label="keyboard shortcuts" title="keyboard shortcuts (?)">
        ?
      </button>
      <button
        type="button"
        className="panel-toggle"
        aria-pressed={panels.rightOpen}
        aria-label={panels.rightOpen ? "hide the inspector panel" : "show the inspector panel"}
        title="show or hide the inspector, problems, changes and runs"
        onClick={() => on.setPanels({ rightOpen: !panels.rightOpen })}
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
            <button type="button" onClick={() => { on.setNotice(null); notice.action.run(); }}>
              {notice.action.label}
            </button>
          )}
          <button type="button" className="link" onClick={() => on.setNotice(null)} aria-label="dismiss">
            ×
          </button>
        </span>
      )}
    </header>
  );
}
