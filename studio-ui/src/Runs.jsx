// Running the graph as edited, following the run, and reading the results: the score table
// with pass and fail, the PPIs of every moment, and two runs side by side.
import { useEffect, useRef, useState } from "react";
import { imageUrl } from "./api.js";

const fmt = (v, digits = 4) => (v === null || v === undefined || Number.isNaN(v) ? "–" : Number(v).toPrecision(digits));
const signed = (v) => (v === null || v === undefined ? "–" : `${v > 0 ? "+" : ""}${Number(v).toPrecision(3)}`);

// What the user chose in the form, per graph file: kept while the page lives, so that the
// form (drawn only while its tab is open) comes back as it was left.
const chosen = new Map();

export function RunForm({ graphPath, choices, truths, onRun, running, graphValid }) {
  const kept = chosen.get(graphPath) || {};
  const [truth, setTruth] = useState(kept.truth ?? "");
  const [sector, setSector] = useState(kept.sector ?? (choices?.sector || ""));
  const [level, setLevel] = useState(kept.level ?? (choices?.current || ""));
  const [seed, setSeed] = useState(kept.seed ?? "0");
  const levels = choices?.levels || [];
  const remember = (key, value) => chosen.set(graphPath, { ...(chosen.get(graphPath) || {}), [key]: value });
  // The graph's own sector and level, until the user picks others (per graph file).
  useEffect(() => {
    const mine = chosen.get(graphPath) || {};
    setTruth(mine.truth ?? "");
    setSeed(mine.seed ?? "0");
    setSector(mine.sector ?? (choices?.sector || ""));
    setLevel(mine.level ?? (choices?.current || ""));
  }, [graphPath, choices?.sector, choices?.current]);
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
        <select
          value={truth}
          onChange={(e) => {
            remember("truth", e.target.value);
            setTruth(e.target.value);
          }}
          data-testid="run-truth"
        >
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
          onChange={(e) => {
            remember("sector", e.target.value);
            setSector(e.target.value);
          }}
          placeholder={choices?.sector ? `as in the graph: ${choices.sector}` : "AZ0:AZ1"}
          data-testid="run-sector"
        />
      </label>
      <label>
        fidelity
        <select
          value={level}
          onChange={(e) => {
            remember("level", e.target.value);
            setLevel(e.target.value);
          }}
          data-testid="run-level"
        >
          <option value="">as in the graph{choices?.current ? ` (${choices.current})` : ""}</option>
          {levels.map((l) => (
            <option key={l.label} value={l.label} title={Object.entries(l.set).map(([k, v]) => `${l.block}.${k}=${v}`).join(" ")}>
              {l.label}
            </option>
          ))}
        </select>
      </label>
      <label>
        seed
        <input
          value={seed}
          onChange={(e) => {
            remember("seed", e.target.value);
            setSeed(e.target.value);
          }}
          data-testid="run-seed"
        />
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

function RunName({ run, onShow, onRename }) {
  const [editing, setEditing] = useState(false);
  const [text, setText] = useState(run.label);
  useEffect(() => setText(run.label), [run.label]);
  if (editing)
    return (
      <input
        className="run-name-input"
        value={text}
        autoFocus
        aria-label={`name of run ${run.id}`}
        data-testid={`run-name-${run.id}`}
        onChange={(e) => setText(e.target.value)}
        onBlur={() => {
          setEditing(false);
          if (text.trim() && text !== run.label) onRename(run.id, text.trim());
        }}
        onKeyDown={(e) => {
          if (e.key === "Enter") e.currentTarget.blur();
          if (e.key === "Escape") {
            setText(run.label);
            setEditing(false);
          }
        }}
      />
    );
  return (
    <div className="run-name">
      <button type="button" className="link run-label" onClick={() => onShow(run.id)} onDoubleClick={() => setEditing(true)}>
        {run.label}
      </button>
      <button
        type="button"
        className="link"
        onClick={() => setEditing(true)}
        aria-label={`rename run ${run.id}`}
        title="rename this run"
        data-testid={`rename-${run.id}`}
      >
        ✎
      </button>
    </div>
  );
}

export function RunList({ runs, shown, compare, onShow, onCompare, onCancel, onRename }) {
  if (!runs.length) return <div className="muted">No runs yet.</div>;
  return (
    <div className="run-list" data-testid="run-list">
      {runs.map((r) => (
        <div key={r.id} className={`run-item ${r.state}${shown === r.id ? " shown" : ""}`} data-testid={`run-${r.id}`}>
          <RunName run={r} onShow={onShow} onRename={onRename} />
          <div className="run-state">
            {r.state === "running" || r.state === "starting" ? (
              <>
                <progress max="1" value={r.progress} data-testid={`run-progress-${r.id}`} /> {r.phase}{" "}
                <button type="button" className="link" onClick={() => onCancel(r.id)} aria-label={`cancel run ${r.id}`}>
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
                aria-label={`compare run ${r.id}`}
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
                <Picture src={imageUrl(run.id, m)} alt={`${m}: truth, estimate and error`} />
              </figure>
            ))}
          </div>
        </div>
      )}
    </div>
  );
}

// A picture that opens large on a click (Escape or a click closes it).
export function Picture({ src, alt }) {
  const [open, setOpen] = useState(false);
  useEffect(() => {
    if (!open) return;
    const key = (e) => e.key === "Escape" && setOpen(false);
    window.addEventListener("keydown", key);
    return () => window.removeEventListener("keydown", key);
  }, [open]);
  return (
    <>
      <button type="button" className="picture" onClick={() => setOpen(true)} aria-label={`open large: ${alt}`}>
        <img src={src} alt={alt} loading="lazy" />
      </button>
      {open && (
        <div className="lightbox" role="dialog" aria-modal="true" aria-label={alt} onClick={() => setOpen(false)} data-testid="lightbox">
          <img src={src} alt={alt} />
          <button type="button" className="lightbox-close" onClick={() => setOpen(false)} aria-label="close the picture">
            ×
          </button>
        </div>
      )}
    </>
  );
}

// Where two pictures differ: |B − A| per pixel (black where they are the same). Both runs
// are drawn on fixed colour scales and the same map, so what lights up is what changed.
function Difference({ a, b, moment }) {
  const ref = useRef(null);
  const [note, setNote] = useState("computing…");
  useEffect(() => {
    let live = true;
    const load = (src) =>
      new Promise((resolve, reject) => {
        const img = new Image();
        img.onload = () => resolve(img);
        img.onerror = reject;
        img.src = src;
      });
    Promise.all([load(a), load(b)])
      .then(([ia, ib]) => {
        if (!live || !ref.current) return;
        const canvas = ref.current;
        canvas.width = Math.max(ia.naturalWidth, ib.naturalWidth);
        canvas.height = Math.max(ia.naturalHeight, ib.naturalHeight);
        const ctx = canvas.getContext("2d");
        ctx.fillStyle = "#fff";
        ctx.fillRect(0, 0, canvas.width, canvas.height);
        ctx.drawImage(ia, 0, 0);
        ctx.globalCompositeOperation = "difference";
        ctx.drawImage(ib, 0, 0);
        const data = ctx.getImageData(0, 0, canvas.width, canvas.height).data;
        let changed = 0;
        for (let i = 0; i < data.length; i += 4) if (data[i] + data[i + 1] + data[i + 2] > 24) changed += 1;
        const share = (100 * changed) / (data.length / 4);
        setNote(changed ? `${share.toFixed(1)} % of the picture differs` : "the two pictures are identical");
      })
      .catch(() => live && setNote("the pictures could not be loaded"));
    return () => {
      live = false;
    };
  }, [a, b]);
  return (
    <figure className="difference" data-testid={`compare-diff-${moment}`}>
      <figcaption>
        |B − A|: {moment} <span className="muted">{note}</span>
      </figcaption>
      <canvas ref={ref} role="img" aria-label={`where the ${moment} pictures of A and B differ`} />
    </figure>
  );
}

function first(scores) {
  const v = Object.values(scores || {});
  return v.length ? v[0] : null;
}

export function Comparison({ data }) {
  const [view, setView] = useState("side");
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
      <div className="row compare-view" role="group" aria-label="how to show the pictures">
        <span className="muted">Pictures:</span>
        <button type="button" aria-pressed={view === "side"} onClick={() => setView("side")} data-testid="view-side">
          side by side
        </button>
        <button type="button" aria-pressed={view === "diff"} onClick={() => setView("diff")} data-testid="view-diff">
          difference |B − A|
        </button>
      </div>
      <div className="images side-by-side">
        {a.images.map((m) => (
          <div className="pair" key={m} data-testid={`compare-ppi-${m}`}>
            {view === "side" && (
              <>
                <figure>
                  <figcaption>A: {m}</figcaption>
                  <Picture src={imageUrl(a.id, m)} alt={`run A ${m}`} />
                </figure>
                {b.images.includes(m) && (
                  <figure>
                    <figcaption>B: {m}</figcaption>
                    <Picture src={imageUrl(b.id, m)} alt={`run B ${m}`} />
                  </figure>
                )}
              </>
            )}
            {view === "diff" && b.images.includes(m) && (
              <Difference a={imageUrl(a.id, m)} b={imageUrl(b.id, m)} moment={m} />
            )}
          </div>
        ))}
      </div>
    </div>
  );
}
