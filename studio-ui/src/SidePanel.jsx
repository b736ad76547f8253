// The panel beside the canvas: the inspector, the engine's problems, the changes a save
// writes, the runs, and the folder's studies.
import Studies from "./Studies.jsx";

const TABS = [
  ["inspect", () => "Inspector"],
  ["problems", (p) => `Problems (${p.problems.length})`],
  ["changes", (p) => (p.validation?.changed ? "Changes •" : "Changes")],
  ["run", (p) => (p.running ? "Run •" : "Run")],
  ["studies", () => "Studies"],
];

export default function SidePanel(props) {
  const { tab, setTab, problems, validation, inspector, runs, graph, onProblem } = props;
  return (
    <>
      <nav className="tabs" aria-label="panels">
        {TABS.map(([k, label]) => (
          <button
            type="button"
            key={k}
            className={tab === k ? "active" : ""}
            aria-pressed={tab === k}
            onClick={() => setTab(k)}
            data-testid={`tab-${k}`}
          >
            {label(props)}
          </button>
        ))}
      </nav>
      <div className="tab-body">
        {tab === "inspect" && inspector}
        {tab === "problems" && (
          <div className="problems" data-testid="problems">
            {!problems.length && <div className="message ok">The engine finds no problem in this graph.</div>}
            {problems.map((p) => (
              <button type="button" key={p.text} className="problem clickable" onClick={() => onProblem(p)}>
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
        {tab === "run" && runs}
        {tab === "studies" && <Studies />}
      </div>
    </>
  );
}
