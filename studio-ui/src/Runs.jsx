// Running the graph as edited, following the run, and reading the results: the score table
// with pass and fail, the PPIs of every moment, and two runs side by side.
import { useEffect, useState } from "react";
import { imageUrl } from "./api.js";

const fmt = (v, digits = 4) => (v === null || v === undefined || Number.isNaN(v) ? "–" : Number(v).toPrecision(digits));
const signed = (v) => (v === null || v === undefined ? "–" : `${v > 0 ? "+" : ""}${Number(v).toPrecision(3)}`);

export function RunForm({ choices, truths, onRun, running, graphValid }) {
  const [truth, setTruth] = useState("");
  const [sector, setSector] = useState("280:290");
  const [level, setLevel] = useState("");
  const [seed, setSeed] = useState("0");
  const levels = choices?.levels || [];
  useEffect(() => {
    // Default to the fastest level that still draws noise ("combined"), if the graph has one.
    if (!level && levels.some((l) => l.label === "combined")) setLevel("combined");
  }, [levels, level]);
  return (
    <form
      className="run-form"
      data-testid="run-form"
      onSubmit={(e) => {
        e.preventDefault();
        onRun({ truth, sector, level, seed: Number.parseInt(seed, 10) });
      }}
    >
      <label>
        truth
        <select value={truth} onChange={(e) => setTruth(e.target.value)} data-testid="run-truth">
          <option value="">as in the graph (empty path: the bundled KLBB scene)</option>
          {truths.map((t) => (
            <option key={t} value={t}>
              {t}
            </option>
          ))}
        </select>
      </label>
      <label>
        sector (deg)
        <input
          value={sector}
          onChange={(e) => setSector(e.target.value)}
          placeholder={choices?.sector ? `as in the graph: ${choices.sector}` : "AZ0:AZ1"}
          data-testid="run-sector"
        />
      </label>
      <label>
        fidelity
        <select value={level} onChange={(e) => setLevel(e.target.value)} data-testid="run-level">
          <option value="">as in the graph</option>
          {levels.map((l) => (
            <option key={l.label} value={l.label} title={Object.entries(l.set).map(([k, v]) => `${l.block}.${k}=${v}`).join(" ")}>
              {l.label}
            </option>
          ))}
        </select>
      </label>
      <label>
        seed
        <input value={seed} onChange={(e) => setSeed(e.target.value)} data-testid="run-seed" />
      </label>
      <button type="submit" className="primary" disabled={running} data-testid="run-button">
        {running ? "Running…" : "Run"}
      </button>
      {!graphValid && <div className="message warn">The graph has problems; the run will report them.</div>}
      <div className="muted">
        Runs the graph as edited (saved or not) with <code>pasim run</code> in its own process.
      </div>
    </form>
  );
}

export function RunList({ runs, shown, compare, onShow, onCompare, onCancel }) {
  if (!runs.length) return <div className="muted">No runs yet.</div>;
  return (
    <div className="run-list" data-testid="run-list">
      {runs.map((r) => (
        <div key={r.id} className={`run-item ${r.state}${shown === r.id ? " shown" : ""}`} data-testid={`run-${r.id}`}>
          <button type="button" className="link run-label" onClick={() => onShow(r.id)}>
            {r.label}
          </button>
          <div className="run-state">
            {r.state === "running" || r.state === "starting" ? (
              <>
                <progress max="1" value={r.progress} data-testid={`run-progress-${r.id}`} /> {r.phase}{" "}
                <button type="button" className="link" onClick={() => onCancel(r.id)}>
                  cancel
                </button>
              </>
            ) : (
              <span>
                {r.state === "drawing" ? "drawing the PPIs…" : r.state} ({r.seconds} s)
              </span>
            )}
          </div>
          {r.state === "done" && (
            <label className="compare-pick">
              <input
                type="checkbox"
                checked={compare.includes(r.id)}
                onChange={() => onCompare(r.id)}
                data-testid={`compare-${r.id}`}
              />
              compare
            </label>
          )}
        </div>
      ))}
    </div>
  );
}

function ScoreTable({ scores }) {
  const rows = Object.entries(scores || {});
  if (!rows.length) return <div className="muted">This run holds no scores (the graph has no scorer).</div>;
  return (
    <table className="scores" data-testid="score-table">
      <thead>
        <tr>
          <th>moment</th>
          <th>bias</th>
          <th>std</th>
          <th>gates</th>
          <th>required |bias| / std</th>
          <th>verdict</th>
        </tr>
      </thead>
      <tbody>
        {rows.map(([m, s]) => (
          <tr key={m} className={s.pass ? "pass" : "fail"}>
            <td>{m}</td>
            <td>{fmt(s.bias)}</td>
            <td>{fmt(s.std)}</td>
            <td>{s.count}</td>
            <td>
              {s.requirement_bias} / {s.requirement_std} {s.units}
            </td>
            <td className="verdict">{s.pass ? "pass" : "fail"}</td>
          </tr>
        ))}
      </tbody>
    </table>
  );
}

export function RunResult({ run }) {
  if (!run) return <div className="muted">Run the graph to see its PPIs and scores here.</div>;
  return (
    <div className="run-result" data-testid="run-result">
      <div className="result-head">
        <b>{run.label}</b> <span className="muted">{run.state}, {run.seconds} s</span>
      </div>
      {run.state === "failed" && (
        <pre className="message error" data-testid="run-error">
          {run.error}
        </pre>
      )}
      {(run.state === "running" || run.state === "starting") && (
        <div>
          <progress max="1" value={run.progress} /> {run.phase}
          <pre className="log">{run.log.slice(-8).join("\n")}</pre>
        </div>
      )}
      {run.notes?.length > 0 && run.notes.map((n) => <div className="message warn" key={n}>note: {n}</div>)}
      {run.state === "done" && (
        <div className="result-body">
          <div className="result-scores">
            <ScoreTable scores={run.scores} />
            {first(run.scores) && <div className="muted scored-rule">scored gates: {first(run.scores).scored}</div>}
          </div>
          <div className="images">
            {run.images.map((m) => (
              <figure key={m} data-testid={`ppi-${m}`}>
                <img src={imageUrl(run.id, m)} alt={`${m}: truth, estimate and error`} loading="lazy" />
              </figure>
            ))}
          </div>
        </div>
      )}
    </div>
  );
}

function first(scores) {
  const v = Object.values(scores || {});
  return v.length ? v[0] : null;
}

export function Comparison({ data }) {
  if (!data) return null;
  const { a, b, rows } = data;
  const better = (x) => (x < 0 ? "better" : x > 0 ? "worse" : "");
  return (
    <div className="comparison" data-testid="comparison">
      <div className="result-head">
        <b>A</b> {a.label} &nbsp;vs&nbsp; <b>B</b> {b.label}
      </div>
      <div className="compare-top">
      <table className="scores" data-testid="compare-table">
        <thead>
          <tr>
            <th>moment</th>
            <th>bias A</th>
            <th>bias B</th>
            <th>|bias| B−A</th>
            <th>std A</th>
            <th>std B</th>
            <th>std B−A</th>
            <th>A</th>
            <th>B</th>
          </tr>
        </thead>
        <tbody>
          {rows.map((r) => (
            <tr key={r.moment}>
              <td>{r.moment}</td>
              <td>{fmt(r.a?.bias)}</td>
              <td>{fmt(r.b?.bias)}</td>
              <td className={better(r.abs_bias_change)}>{signed(r.abs_bias_change)}</td>
              <td>{fmt(r.a?.std)}</td>
              <td>{fmt(r.b?.std)}</td>
              <td className={better(r.std_change)}>{signed(r.std_change)}</td>
              <td className={r.a?.pass ? "pass" : "fail"}>{r.a ? (r.a.pass ? "pass" : "fail") : "–"}</td>
              <td className={r.b?.pass ? "pass" : "fail"}>{r.b ? (r.b.pass ? "pass" : "fail") : "–"}</td>
            </tr>
          ))}
        </tbody>
      </table>
      <div className="compare-diffs">
        <div>
          <div className="panel-subtitle">What differs in the graph (A → B)</div>
          <pre className="diff" data-testid="compare-graph-diff">{data.graph_diff || "the same graph"}</pre>
        </div>
        {Object.keys(data.options_diff).length > 0 && (
          <div>
            <div className="panel-subtitle">Run options (A → B)</div>
            <pre className="diff">
              {Object.entries(data.options_diff)
                .map(([k, [x, y]]) => `${k}: ${x ?? "as in the graph"} → ${y ?? "as in the graph"}`)
                .join("\n")}
            </pre>
          </div>
        )}
      </div>
      </div>
      <div className="images side-by-side">
        {a.images.map((m) => (
          <div className="pair" key={m} data-testid={`compare-ppi-${m}`}>
            <figure>
              <figcaption>A: {m}</figcaption>
              <img src={imageUrl(a.id, m)} alt={`run A ${m}`} loading="lazy" />
            </figure>
            {b.images.includes(m) && (
              <figure>
                <figcaption>B: {m}</figcaption>
                <img src={imageUrl(b.id, m)} alt={`run B ${m}`} loading="lazy" />
              </figure>
            )}
          </div>
        ))}
      </div>
    </div>
  );
}
