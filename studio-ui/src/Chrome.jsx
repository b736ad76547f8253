// The page's furniture around the canvas: resizable splitters, the context menu, the list of
// keyboard shortcuts, the legend of wire colours and the radar at a glance.
import { useEffect, useRef } from "react";

// A bar between two panels: drag it, or focus it and use the arrow keys.
export function Splitter({ label, orientation, value, min, max, onChange, invert = false, className = "" }) {
  const clamp = (v) => Math.max(min, Math.min(max, Math.round(v)));
  const vertical = orientation === "vertical";
  const onPointerDown = (e) => {
    e.preventDefault();
    const start = vertical ? e.clientX : e.clientY;
    const from = value;
    const move = (ev) => {
      const d = (vertical ? ev.clientX : ev.clientY) - start;
      onChange(clamp(from + (invert ? -d : d)));
    };
    const up = () => {
      window.removeEventListener("pointermove", move);
      window.removeEventListener("pointerup", up);
    };
    window.addEventListener("pointermove", move);
    window.addEventListener("pointerup", up);
  };
  const onKeyDown = (e) => {
    const grow = vertical ? (invert ? "ArrowLeft" : "ArrowRight") : invert ? "ArrowUp" : "ArrowDown";
    const shrink = vertical ? (invert ? "ArrowRight" : "ArrowLeft") : invert ? "ArrowDown" : "ArrowUp";
    if (e.key === grow) onChange(clamp(value + 20));
    else if (e.key === shrink) onChange(clamp(value - 20));
    else return;
    e.preventDefault();
  };
  return (
    <div
      role="separator"
      aria-orientation={vertical ? "vertical" : "horizontal"}
      aria-label={label}
      aria-valuenow={value}
      aria-valuemin={min}
      aria-valuemax={max}
      tabIndex={0}
      className={`splitter ${vertical ? "vertical" : "horizontal"} ${className}`}
      onPointerDown={onPointerDown}
      onKeyDown={onKeyDown}
      title={`${label} (drag, or arrow keys)`}
    />
  );
}

// A menu at the pointer: a list of actions, each with its shortcut.
export function ContextMenu({ menu, onClose }) {
  const ref = useRef(null);
  useEffect(() => {
    ref.current?.querySelector("button")?.focus();
    const close = (e) => {
      if (!ref.current?.contains(e.target)) onClose();
    };
    const key = (e) => e.key === "Escape" && onClose();
    window.addEventListener("pointerdown", close, true);
    window.addEventListener("keydown", key);
    return () => {
      window.removeEventListener("pointerdown", close, true);
      window.removeEventListener("keydown", key);
    };
  }, [onClose]);
  const left = Math.min(menu.x, window.innerWidth - 220);
  const top = Math.min(menu.y, window.innerHeight - 34 * menu.items.length - 12);
  return (
    <div ref={ref} className="context-menu" role="menu" aria-label={menu.label} style={{ left, top }} data-testid="context-menu">
      {menu.items.map((item) => (
        <button
          type="button"
          role="menuitem"
          key={item.label}
          disabled={item.disabled}
          onClick={() => {
            onClose();
            item.run();
          }}
          data-testid={`menu-${item.label.toLowerCase().replaceAll(/[^a-z]+/g, "-")}`}
        >
          <span>{item.label}</span>
          {item.keys && <kbd>{item.keys}</kbd>}
        </button>
      ))}
    </div>
  );
}

export const SHORTCUTS = [
  ["Ctrl+Z", "undo the last edit"],
  ["Ctrl+Shift+Z, Ctrl+Y", "redo"],
  ["Ctrl+S", "save"],
  ["Ctrl+C", "copy the selected blocks (with the wires between them)"],
  ["Ctrl+V", "paste them beside the originals"],
  ["Ctrl+D", "duplicate the selected blocks"],
  ["Ctrl+A", "select every block"],
  ["Delete, Backspace", "delete the selection"],
  ["Shift+click, Ctrl+click", "add a block to the selection"],
  ["Shift+drag", "select the blocks in a box"],
  ["right click", "the actions for a block, a wire or the canvas"],
  ["?", "this list"],
  ["Escape", "close a menu, a dialog or a picture"],
];

export function ShortcutsDialog({ onClose }) {
  const ref = useRef(null);
  useEffect(() => {
    ref.current?.querySelector("button")?.focus();
    const key = (e) => e.key === "Escape" && onClose();
    window.addEventListener("keydown", key);
    return () => window.removeEventListener("keydown", key);
  }, [onClose]);
  return (
    <div className="modal-backdrop" onClick={onClose}>
      <div
        ref={ref}
        className="modal"
        role="dialog"
        aria-modal="true"
        aria-label="Keyboard shortcuts"
        onClick={(e) => e.stopPropagation()}
        data-testid="shortcuts"
      >
        <div className="modal-head">
          <b>Keyboard shortcuts</b>
          <button type="button" onClick={onClose} aria-label="close the shortcuts">
            Close
          </button>
        </div>
        <table className="shortcuts">
          <tbody>
            {SHORTCUTS.map(([k, what]) => (
              <tr key={k}>
                <td>
                  <kbd>{k}</kbd>
                </td>
                <td>{what}</td>
              </tr>
            ))}
          </tbody>
        </table>
      </div>
    </div>
  );
}

// The colour of each kind of signal the graph's wires carry.
export function Legend({ kinds, colors }) {
  if (!kinds.length) return null;
  return (
    <div className="legend" data-testid="legend" aria-label="wire colours by signal kind">
      {kinds.map((k) => (
        <span key={k} className="legend-item">
          <span className="swatch" style={{ background: colors[k] || "#888" }} />
          {k}
        </span>
      ))}
    </div>
  );
}

// The radar at a glance: the server's summary of the graph, one line over the canvas.
export function Glance({ summary }) {
  const rows = summary?.rows || [];
  if (!rows.length) return null;
  const shown = rows.filter((r) => r.key !== "wavelength" && r.key !== "pulse_width");
  return (
    <div className="glance" data-testid="glance" title={rows.map((r) => `${r.label}: ${r.text} (from ${r.from.join(", ")})`).join("\n")}>
      {shown.map((r) => (
        <span key={r.key} className="glance-item">
          <span className="muted">{r.label}</span> <b>{r.key === "transmit_mode" ? r.value.toUpperCase() : r.text}</b>
        </span>
      ))}
    </div>
  );
}

export function SummaryTable({ summary }) {
  const rows = summary?.rows || [];
  return (
    <div className="section" data-testid="system-summary">
      <div className="panel-subtitle">The radar at a glance</div>
      <div className="muted">Derived from the graph's parameters (hover a row for which).</div>
      <table className="summary">
        <tbody>
          {rows.map((r) => (
            <tr key={r.key} data-testid={`summary-${r.key}`} title={`from ${r.from.join(", ")}`}>
              <th scope="row">{r.label}</th>
              <td>{r.text}</td>
            </tr>
          ))}
        </tbody>
      </table>
      {(summary?.missing || []).map((m) => (
        <div className="muted" key={m}>
          {m}
        </div>
      ))}
    </div>
  );
}
