// The panel beside the canvas: the selected block (name, type, swap, parameters with their
// declared units, bounds and docs, ports with their types), the selected wire, or the graph.
// Problems shown here are the engine's own messages, matched to the block and item they name.
import { useEffect, useState } from "react";
import { connText, typeText } from "./api.js";

function problemsFor(problems, block, item) {
  return problems.filter((p) => p.block === block && (item === undefined || p.item === item));
}

function ValueInput({ value, onCommit, placeholder, testid, disabled, choices, kind, label, id }) {
  const [text, setText] = useState(value ?? "");
  useEffect(() => setText(value ?? ""), [value]);
  const commit = (t) => {
    if ((t ?? "") !== (value ?? "")) onCommit(t);
  };
  if (choices || kind === "bool") {
    const opts = kind === "bool" ? ["true", "false"] : choices.map((c) => String(c));
    const known = opts.includes(text) || text === "";
    return (
      <select
        value={text}
        disabled={disabled}
        data-testid={testid}
        aria-label={label}
        id={id}
        onChange={(e) => {
          setText(e.target.value);
          commit(e.target.value);
        }}
      >
        <option value="">{placeholder}</option>
        {opts.map((o) => (
          <option key={o} value={o}>
            {o}
          </option>
        ))}
        {!known && <option value={text}>{text}</option>}
      </select>
    );
  }
  return (
    <input
      type="text"
      value={text}
      placeholder={placeholder}
      disabled={disabled}
      data-testid={testid}
      aria-label={label}
      id={id}
      spellCheck={false}
      onChange={(e) => setText(e.target.value)}
      onBlur={() => commit(text)}
      onKeyDown={(e) => {
        if (e.key === "Enter") commit(text);
        if (e.key === "Escape") setText(value ?? "");
      }}
    />
  );
}

function bounds(p) {
  if (p.choices) return `one of ${p.choices.join(", ")}`;
  const lo = p.minimum !== undefined ? p.minimum : null;
  const hi = p.maximum !== undefined ? p.maximum : null;
  if (lo === null && hi === null) return p.type;
  return `${p.type} in [${lo ?? "-∞"}, ${hi ?? "∞"}]`;
}

function defaultText(p) {
  if (p.required) return "required";
  if (p.default === null || p.default === undefined) return "unset";
  return `default ${typeof p.default === "string" ? p.default || "''" : String(p.default)}`;
}

function entries(items) {
  if (!items || typeof items !== "object") return [];
  return Array.isArray(items) ? items.map((v) => [v.name, v]) : Object.entries(items);
}

function Schema({ schema }) {
  // The Dataset a port carries, as the engine declares it (variables, then attributes).
  if (!schema) return null;
  const vars = entries(schema.variables);
  const attrs = entries(schema.attrs);
  if (!vars.length && !attrs.length) return <pre className="schema">{JSON.stringify(schema, null, 1)}</pre>;
  return (
    <details className="schema">
      <summary>
        Dataset: {vars.length} variables{attrs.length ? `, ${attrs.length} attributes` : ""}
      </summary>
      <ul>
        {vars.map(([name, v]) => (
          <li key={name} title={v?.doc || ""}>
            <code>{name}</code>{" "}
            {typeof v === "object" && v !== null
              ? [v.dtype, v.dims && `(${[].concat(v.dims).join(", ")})`, v.units].filter(Boolean).join(" ")
              : String(v)}
            {v?.required === false && <span className="muted"> optional</span>}
          </li>
        ))}
        {attrs.map(([name, a]) => (
          <li key={`@${name}`} title={a?.doc || ""}>
            <code>@{name}</code> {a?.type}
            {a?.required === false && <span className="muted"> optional</span>}
          </li>
        ))}
      </ul>
    </details>
  );
}

function Ports({ title, ports, side, wires, colors }) {
  if (!ports.length) return null;
  return (
    <div className="section">
      <div className="panel-subtitle">{title}</div>
      {ports.map((p) => (
        <div className="port-info" key={p.name} data-testid={`port-${side}-${p.name}`}>
          <div>
            <span className="swatch" style={{ background: colors[p.type?.kind] || "#888" }} />
            <b>{p.name}</b>
            {side === "in" && !p.required && <span className="muted"> optional</span>}
            {p.store && <span className="muted"> stored as {p.store}</span>}
          </div>
          <code className="type-text">{typeText(p.type)}</code>
          {p.doc && <div className="muted">{p.doc}</div>}
          {p.fields?.length > 0 && <div className="muted">fields: {p.fields.join(", ")}</div>}
          <Schema schema={p.type?.schema} />
          {wires[p.name]?.length > 0 && (
            <div className="muted">{side === "in" ? "from" : "to"} {wires[p.name].join(", ")}</div>
          )}
        </div>
      ))}
    </div>
  );
}

function SwapBox({ name, block, options, onSwap, swapMessage, editable }) {
  const [choice, setChoice] = useState("");
  useEffect(() => setChoice(""), [name, block.type]);
  if (!options) return <div className="muted">looking up the types that fit…</div>;
  const fits = options.options.filter((o) => o.fits);
  const misfits = options.options.filter((o) => !o.fits);
  const picked = options.options.find((o) => o.type === choice);
  return (
    <div className="section swap">
      <div className="panel-subtitle">Swap type</div>
      <div className="row">
        <select
          value={choice}
          onChange={(e) => setChoice(e.target.value)}
          data-testid="swap-select"
          aria-label={`new type for '${name}'`}
          disabled={!editable}
        >
          <option value="">choose a type…</option>
          <optgroup label={`fits the wires of '${name}' (${fits.length})`}>
            {fits.map((o) => (
              <option key={o.type} value={o.type} title={o.doc}>
                {o.type}
              </option>
            ))}
          </optgroup>
          <optgroup label={`does not fit (${misfits.length})`}>
            {misfits.map((o) => (
              <option key={o.type} value={o.type} title={o.reasons.join("\n")}>
                {o.type} ✗
              </option>
            ))}
          </optgroup>
        </select>
        <button type="button" disabled={!choice || !editable} onClick={() => onSwap(choice)} data-testid="swap-button">
          Swap
        </button>
      </div>
      {picked && (
        <div className="muted swap-preview">
          {picked.fits ? "fits every wire" : `does not fit: ${picked.reasons.join("; ")}`}
          {picked.fits && picked.drops.length > 0 && `; drops ${picked.drops.join(", ")}`}
          {picked.fits && picked.needs_wiring.length > 0 && `; then needs ${picked.needs_wiring.join(", ")} wired`}
        </div>
      )}
      {swapMessage && (
        <div className={`message ${swapMessage.ok ? "ok" : "error"}`} data-testid="swap-message">
          {swapMessage.text}
        </div>
      )}
    </div>
  );
}

function BlockPanel(props) {
  const { name, block, face, doc, problems, colors, onParam, onRename, onDelete, editable } = props;
  const [rename, setRename] = useState(name);
  useEffect(() => setRename(name), [name]);
  const params = block.params || {};
  const declared = face ? face.params : [];
  const undeclared = Object.keys(params).filter((k) => !declared.some((p) => p.name === k));
  const wires = { in: {}, out: {} };
  for (const c of doc.connections) {
    if (c.dst === name) (wires.in[c.dst_port ?? face?.inputs?.[0]?.name] ||= []).push(c.src_port ? `${c.src}.${c.src_port}` : c.src);
    if (c.src === name) (wires.out[c.src_port ?? face?.outputs?.[0]?.name] ||= []).push(c.dst_port ? `${c.dst}.${c.dst_port}` : c.dst);
  }
  const blockProblems = problemsFor(problems, name).filter((p) => !p.item.startsWith("parameter '"));
  return (
    <div className="inspector" data-testid="inspector-block">
      <div className="row">
        <input
          className="name-input"
          value={rename}
          disabled={!editable}
          onChange={(e) => setRename(e.target.value)}
          onBlur={() => rename !== name && onRename(name, rename, () => setRename(name))}
          onKeyDown={(e) => e.key === "Enter" && rename !== name && onRename(name, rename, () => setRename(name))}
          aria-label="block name"
          data-testid="block-name"
        />
        <button type="button" className="danger" disabled={!editable} onClick={() => onDelete(name)}>
          Delete block
        </button>
      </div>
      <div className="block-type-line">
        <code>{block.type}</code> {face ? <span className="muted">{face.doc}</span> : <span className="error-text">not a registered block type</span>}
      </div>
      {face?.description && face.description !== face.doc && (
        <details className="description">
          <summary>description</summary>
          <pre>{face.description}</pre>
        </details>
      )}
      {blockProblems.length > 0 && (
        <div className="section">
          {blockProblems.map((p) => (
            <div className="problem" key={p.text}>
              {p.item}: {p.message}
            </div>
          ))}
        </div>
      )}
      <SwapBox {...props} />
      <div className="section">
        <div className="panel-subtitle">Parameters</div>
        {declared.length === 0 && undeclared.length === 0 && <div className="muted">none</div>}
        {declared.map((p) => {
          const errs = problemsFor(problems, name, `parameter '${p.name}'`);
          return (
            <div className={`param${errs.length ? " bad" : ""}`} key={p.name} data-testid={`param-${p.name}`}>
              <div className="param-head">
                <label htmlFor={`param-${name}-${p.name}`}>
                  <b>{p.name}</b>
                </label>
                <span className="muted">
                  {p.units && <span className="units">{p.units}</span>} {bounds(p)}
                </span>
              </div>
              <ValueInput
                value={params[p.name]}
                placeholder={defaultText(p)}
                choices={p.choices}
                kind={p.type}
                disabled={!editable}
                testid={`param-input-${p.name}`}
                id={`param-${name}-${p.name}`}
                label={`${p.name}${p.units ? ` (${p.units})` : ""}`}
                onCommit={(t) => onParam(name, p.name, t)}
              />
              {p.doc && <div className="muted param-doc">{p.doc}</div>}
              {errs.map((e) => (
                <div className="problem" key={e.text} data-testid={`param-problem-${p.name}`}>
                  {e.message}
                </div>
              ))}
            </div>
          );
        })}
        {undeclared.map((k) => (
          <div className="param bad" key={k} data-testid={`param-${k}`}>
            <div className="param-head">
              <b>{k}</b>
              <button type="button" className="link" disabled={!editable} onClick={() => onParam(name, k, "")}>
                remove
              </button>
            </div>
            <code>{params[k]}</code>
            {problemsFor(problems, name, `parameter '${k}'`).map((e) => (
              <div className="problem" key={e.text}>
                {e.message}
              </div>
            ))}
          </div>
        ))}
      </div>
      {face && (
        <>
          <Ports title="Inputs" ports={face.inputs} side="in" wires={wires.in} colors={colors} />
          <Ports title="Outputs" ports={face.outputs} side="out" wires={wires.out} colors={colors} />
        </>
      )}
    </div>
  );
}

function WirePanel({ wire, faces, doc, problems, onDeleteWire, editable }) {
  const src = faces[doc.blocks[wire.src]?.type];
  const dst = faces[doc.blocks[wire.dst]?.type];
  const out = src?.outputs.find((p) => p.name === wire.src_port) || (src?.outputs.length === 1 ? src.outputs[0] : null);
  const inp = dst?.inputs.find((p) => p.name === wire.dst_port) || (dst?.inputs.length === 1 ? dst.inputs[0] : null);
  const text = wire.text;
  const errs = problems.filter((p) => p.item.includes(text) || p.message.includes(`'${text}'`));
  return (
    <div className="inspector" data-testid="inspector-wire">
      <div className="panel-subtitle">Wire</div>
      <code className="wire-text">{text}</code>
      <div className="section">
        <div>
          output: <code>{typeText(out?.type)}</code>
        </div>
        <div>
          input: <code>{typeText(inp?.type)}</code>
        </div>
      </div>
      {errs.map((e) => (
        <div className="problem" key={e.text}>
          {e.message}
        </div>
      ))}
      <button type="button" className="danger" disabled={!editable} onClick={() => onDeleteWire(text)}>
        Delete wire
      </button>
    </div>
  );
}

function GraphPanel({ graph, doc, validation, onVariable, editable, summaryTable }) {
  const [newName, setNewName] = useState("");
  return (
    <div className="inspector" data-testid="inspector-graph">
      <div className="panel-subtitle">Graph</div>
      <div>
        <code>{graph.path}</code>: {Object.keys(doc.blocks).length} blocks, {doc.connections.length} wires
      </div>
      {!graph.canonical && graph.editable && (
        <div className="message warn">
          This file is not in canonical form: saving rewrites it sorted, without comments.
        </div>
      )}
      {!graph.editable && (
        <div className="message error">
          The file cannot be read completely (see Problems); edit it by hand, the studio only shows it.
        </div>
      )}
      {summaryTable}
      <div className="section">
        <div className="panel-subtitle">Variables</div>
        {Object.entries(doc.variables || {}).map(([k, v]) => (
          <div className="param" key={k}>
            <div className="param-head">
              <b>${k}</b>
              <button type="button" className="link" disabled={!editable} onClick={() => onVariable(k, null)}>
                remove
              </button>
            </div>
            <ValueInput
              value={v}
              placeholder="value"
              disabled={!editable}
              label={`value of $${k}`}
              testid={`variable-input-${k}`}
              onCommit={(t) => onVariable(k, t)}
            />
          </div>
        ))}
        <div className="row">
          <input
            placeholder="new variable"
            aria-label="name of a new variable"
            data-testid="new-variable"
            value={newName}
            disabled={!editable}
            onChange={(e) => setNewName(e.target.value)}
          />
          <button
            type="button"
            disabled={!newName.trim() || !editable}
            onClick={() => {
              onVariable(newName.trim(), "0.0");
              setNewName("");
            }}
          >
            Add
          </button>
        </div>
      </div>
      <div className="muted section">
        {validation?.valid ? "The engine finds no problem." : `${validation?.problems?.length ?? 0} problems (see Problems).`} Select a
        block or a wire to edit it; drag from the palette to add a block, from an output to an input to add a
        wire; Delete removes the selection.
      </div>
    </div>
  );
}

export default function Inspector(props) {
  const { selection, doc } = props;
  if (selection?.kind === "block" && doc.blocks[selection.id]) {
    const block = doc.blocks[selection.id];
    return <BlockPanel {...props} name={selection.id} block={block} face={props.faces[block.type]} />;
  }
  if (selection?.kind === "wire") {
    const wire = doc.connections.find((c) => connText(c) === selection.id);
    if (wire) return <WirePanel {...props} wire={{ ...wire, text: selection.id }} />;
  }
  return <GraphPanel {...props} />;
}
