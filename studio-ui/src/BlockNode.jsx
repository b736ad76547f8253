// A block on the canvas: its name and type, then one row per port pair, inputs on the left
// and outputs on the right, each a handle coloured by signal kind. The geometry (width,
// header and row heights) comes from the server, the same numbers the automatic layout uses.
import { Handle, Position, useConnection } from "@xyflow/react";
import { memo, useContext } from "react";
import { StudioContext } from "./context.js";
import { typeText } from "./api.js";

function PortHandle({ side, port, color, hollow, hint }) {
  const isInput = side === "in";
  return (
    <Handle
      id={port.name}
      type={isInput ? "target" : "source"}
      position={isInput ? Position.Left : Position.Right}
      className={`port-handle${hint ? ` hint-${hint}` : ""}`}
      style={{ background: hollow ? "#fff" : color, borderColor: color }}
      title={`${port.name}: ${typeText(port.type)}${port.doc ? ` - ${port.doc}` : ""}`}
      data-testid={`handle-${side}-${port.name}`}
    />
  );
}

function BlockNode({ id, data, selected }) {
  const { colors, feeds } = useContext(StudioContext);
  const connection = useConnection();
  const { type, known, inputs, outputs, wiredInputs, problems, keys = [] } = data;
  const rows = Math.max(inputs.length, outputs.length, 1);

  // While a wire is being drawn from an output, mark the inputs it can feed: the server's
  // list, computed with the engine's own rule (PortType.mismatch, schemas included).
  let fits = null;
  if (connection.inProgress && connection.fromHandle?.type === "source" && connection.fromNode?.id !== id) {
    fits = feeds[`${connection.fromNode?.data?.type}:${connection.fromHandle.id}`] || [];
  }
  const hint = (port) => {
    if (!fits) return null;
    return fits.includes(`${type}:${port.name}`) ? "fits" : "no";
  };

  const cells = [];
  for (let i = 0; i < rows; i += 1) {
    const a = inputs[i];
    const b = outputs[i];
    cells.push(
      <div className="port-row" key={i}>
        <div className={`port in${a && !a.required ? " optional" : ""}`}>
          {a && (
            <>
              <PortHandle
                side="in"
                port={a}
                color={colors[a.type?.kind] || "#888"}
                hollow={a.required && !wiredInputs.includes(a.name)}
                hint={hint(a)}
              />
              <span>{a.name}</span>
            </>
          )}
        </div>
        <div className="port out">
          {b && (
            <>
              <span>{b.name}</span>
              <PortHandle side="out" port={b} color={colors[b.type?.kind] || "#888"} />
            </>
          )}
        </div>
      </div>,
    );
  }
  return (
    <div
      className={`block-node${selected ? " selected" : ""}${problems ? " has-problems" : ""}${known ? "" : " unknown"}`}
      data-testid={`block-${id}`}
    >
      <div className="block-header">
        <div className="block-title">
          <div className="block-name">{id}</div>
          {keys.length > 0 && (
            <div
              className="block-keys"
              title={keys.map((k) => `${k.name} = ${k.text}`).join("\n")}
              data-testid={`block-keys-${id}`}
            >
              {keys.map((k) => k.text).join(" · ")}
            </div>
          )}
        </div>
        <div className="block-type">{type}{known ? "" : " (unknown type)"}</div>
        {problems > 0 && (
          <div className="block-badge" title={`${problems} problem${problems > 1 ? "s" : ""}`}>
            {problems}
          </div>
        )}
      </div>
      {cells}
    </div>
  );
}

export default memo(BlockNode);
