// The results dock under the canvas: the run on view, or two runs compared.
import { Comparison, RunResult } from "./Runs.jsx";

export default function Dock({ dock, dockOpen, shown, comparison, onShow, onToggle }) {
  return (
    <section className="dock" data-testid="dock" aria-label="results">
      <nav className="tabs">
        <button type="button" className={dock === "result" ? "active" : ""} onClick={() => onShow("result")}>
          Result{shown ? `: ${shown.label}` : ""}
        </button>
        <button
          type="button"
          className={dock === "compare" ? "active" : ""}
          disabled={!comparison}
          onClick={() => onShow("compare")}
          data-testid="dock-compare"
        >
          Compare{comparison ? ` ${comparison.a.id} ↔ ${comparison.b.id}` : " (tick two runs)"}
        </button>
        <button
          type="button"
          className="link dock-toggle"
          onClick={onToggle}
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
  );
}
