// The session's runs: started from the page, followed while they go, renamed, compared.
// The server keeps them, so a reload asks for them again (see App's loading).
import { useCallback, useEffect, useState } from "react";
import { api } from "./api.js";

export default function useRuns({ graph, doc, say, showDock }) {
  const [runs, setRuns] = useState([]);
  const [shownRun, setShownRun] = useState(null);
  const [compare, setCompare] = useState([]);
  const [comparison, setComparison] = useState(null);

  const startRun = useCallback(
    async (opts) => {
      try {
        const run = await api("runs", { path: graph.path, doc, ...opts });
        setRuns((rs) => [...rs, run]);
        setShownRun(run.id);
        showDock("result");
      } catch (err) {
        say("error", err.message);
      }
    },
    [graph, doc, say], // eslint-disable-line react-hooks/exhaustive-deps
  );

  const active = runs.filter((r) => ["starting", "running", "drawing"].includes(r.state));
  useEffect(() => {
    if (!active.length) return;
    const timer = setInterval(async () => {
      for (const r of active) {
        try {
          const fresh = await api(`runs/${r.id}`);
          setRuns((rs) => rs.map((x) => (x.id === fresh.id ? fresh : x)));
        } catch (err) {
          say("error", err.message);
        }
      }
    }, 400);
    return () => clearInterval(timer);
  }, [active.map((r) => r.id).join(","), say]); // eslint-disable-line react-hooks/exhaustive-deps

  const cancelRun = useCallback(
    async (id) => {
      try {
        const fresh = await api(`runs/${id}/cancel`, {});
        setRuns((rs) => rs.map((x) => (x.id === fresh.id ? fresh : x)));
      } catch (err) {
        say("error", err.message);
      }
    },
    [say],
  );

  const toggleCompare = useCallback((id) => {
    setCompare((c) => (c.includes(id) ? c.filter((x) => x !== id) : [...c, id].slice(-2)));
  }, []);

  useEffect(() => {
    if (compare.length !== 2) {
      setComparison(null);
      return;
    }
    const [a, b] = [...compare].sort((x, y) => Number(x) - Number(y));
    api(`compare?a=${a}&b=${b}`)
      .then((c) => {
        setComparison(c);
        showDock("compare");
      })
      .catch((err) => say("error", err.message));
  }, [compare, say]); // eslint-disable-line react-hooks/exhaustive-deps

  const renameRun = useCallback(
    async (id, label) => {
      try {
        const fresh = await api(`runs/${id}/label`, { label });
        setRuns((rs) => rs.map((x) => (x.id === fresh.id ? { ...x, label: fresh.label } : x)));
      } catch (err) {
        say("error", err.message);
      }
    },
    [say],
  );

  return {
    runs,
    setRuns,
    shownRun,
    setShownRun,
    compare,
    setCompare,
    comparison,
    startRun,
    cancelRun,
    toggleCompare,
    renameRun,
  };
}
