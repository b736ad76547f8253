// Talking to the studio server. Every request carries the session token from the page's
// address; every error the server sends is JSON with a message, shown as it is.

export const token = new URLSearchParams(window.location.search).get("token") || "";

export class ApiError extends Error {
  constructor(status, body) {
    super(body?.error || `HTTP ${status}`);
    this.status = status;
    this.body = body || {};
  }
}

export async function api(path, body) {
  const init = { headers: { Authorization: `token ${token}` } };
  if (body !== undefined) {
    init.method = "POST";
    init.headers["Content-Type"] = "application/json";
    init.body = JSON.stringify(body);
  }
  let res;
  try {
    res = await fetch(`./api/${path}`, init);
  } catch (err) {
    throw new ApiError(0, { error: `the studio server does not answer (${err.message}); is it still running?` });
  }
  let data = null;
  try {
    data = await res.json();
  } catch {
    data = { error: `HTTP ${res.status}: the server's answer is not JSON` };
  }
  if (!res.ok) throw new ApiError(res.status, data);
  return data;
}

export function imageUrl(runId, moment) {
  return `./api/runs/${encodeURIComponent(runId)}/images/${encodeURIComponent(moment)}.png?token=${encodeURIComponent(token)}`;
}

// The connection text the graph file uses: a left-out port stays left out.
export function connText(c) {
  const a = c.src_port ? `${c.src}.${c.src_port}` : c.src;
  const b = c.dst_port ? `${c.dst}.${c.dst_port}` : c.dst;
  return `${a} -> ${b}`;
}

export function subsystem(type) {
  const i = type.indexOf(".");
  return i < 0 ? type : type.slice(0, i);
}

export function typeText(t) {
  if (!t) return "unknown type";
  return t.text || `${t.kind}[${t.dtype}; (${(t.dims || []).join(", ")}); ${t.units}]`;
}
