// A wire: a curve from output to input, coloured by signal kind. A wire the automatic layout
// routed through lanes (it spans several layers) follows them while neither block has moved,
// drawn with the same rule as `pasim graph --format svg` (graph_export.wire_path).
import { BaseEdge, getBezierPath } from "@xyflow/react";
import { memo } from "react";

function curve(a, b) {
  const bend = Math.max(30, Math.abs(b[0] - a[0]) / 2);
  return `C${a[0] + bend},${a[1]} ${b[0] - bend},${b[1]} ${b[0]},${b[1]}`;
}

export function wirePath(points) {
  const out = [`M${points[0][0]},${points[0][1]}`];
  const inner = points.slice(1, -1);
  let prev = points[0];
  for (let j = 0; j + 1 < inner.length; j += 2) {
    out.push(curve(prev, inner[j]));
    out.push(`L${inner[j + 1][0]},${inner[j + 1][1]}`);
    prev = inner[j + 1];
  }
  out.push(curve(prev, points[points.length - 1]));
  return out.join(" ");
}

function WireEdge({ id, sourceX, sourceY, targetX, targetY, sourcePosition, targetPosition, data, selected }) {
  let path;
  if (data?.route?.length) {
    path = wirePath([[sourceX, sourceY], ...data.route, [targetX, targetY]]);
  } else {
    [path] = getBezierPath({ sourceX, sourceY, sourcePosition, targetX, targetY, targetPosition });
  }
  const color = data?.problem ? "#d62728" : data?.color || "#888";
  return (
    <BaseEdge
      id={id}
      path={path}
      style={{
        stroke: color,
        strokeWidth: selected ? 4 : 2,
        strokeDasharray: data?.problem ? "6 4" : undefined,
      }}
      interactionWidth={14}
    />
  );
}

export default memo(WireEdge);
