// Every registered block type (plugins included), grouped by subsystem: the part of the type
// name before the dot. Drag one onto the canvas, or press + to add it.
import { useMemo, useState } from "react";

export default function Palette({ palette, onAdd, editable }) {
  const [filter, setFilter] = useState("");
  const [closed, setClosed] = useState({});
  const byType = useMemo(() => Object.fromEntries(palette.blocks.map((b) => [b.type, b])), [palette]);
  const f = filter.trim().toLowerCase();
  return (
    <div className="palette" data-testid="palette">
      <div className="panel-title">Blocks</div>
      <input
        className="palette-filter"
        placeholder="filter"
        value={filter}
        onChange={(e) => setFilter(e.target.value)}
        aria-label="filter block types"
      />
      {palette.groups.map((g) => {
        const types = g.types.filter(
          (t) => !f || t.toLowerCase().includes(f) || (byType[t]?.doc || "").toLowerCase().includes(f),
        );
        if (!types.length) return null;
        return (
          <div className="palette-group" key={g.name} data-testid={`palette-group-${g.name}`}>
            <button
              type="button"
              className="palette-group-name"
              onClick={() => setClosed({ ...closed, [g.name]: !closed[g.name] })}
            >
              {closed[g.name] ? "▸" : "▾"} {g.name} <span className="muted">({types.length})</span>
            </button>
            {!closed[g.name] &&
              types.map((t) => (
                <div
                  key={t}
                  className="palette-item"
                  draggable={editable}
                  onDragStart={(e) => {
                    e.dataTransfer.setData("application/x-pasim-block", t);
                    e.dataTransfer.effectAllowed = "copy";
                  }}
                  title={byType[t]?.description || byType[t]?.doc || t}
                  data-testid={`palette-item-${t}`}
                >
                  <div className="palette-item-text">
                    <div className="palette-type">{t.slice(g.name.length + 1) || t}</div>
                    <div className="palette-doc">{byType[t]?.doc}</div>
                  </div>
                  <button
                    type="button"
                    className="icon-button"
                    disabled={!editable}
                    onClick={() => onAdd(t)}
                    title={`add a ${t} block`}
                    aria-label={`add ${t}`}
                  >
                    +
                  </button>
                </div>
              ))}
          </div>
        );
      })}
      {palette.broken.length > 0 && (
        <div className="palette-broken">
          <div className="panel-subtitle">Failed to load</div>
          {palette.broken.map((b) => (
            <div key={b.type} className="problem" title={b.error}>
              <b>{b.type}</b>: {b.error}
            </div>
          ))}
        </div>
      )}
    </div>
  );
}
