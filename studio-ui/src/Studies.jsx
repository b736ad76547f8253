// The studies in the served folder (`pasim study --out` folders) and their reports, each
// opened in its own tab. Fetched when the tab is shown, so a study finishing meanwhile appears.
import { useEffect, useState } from "react";
import { api, token } from "./api.js";

export function reportUrl(path) {
  return `./studies/report?path=${encodeURIComponent(path)}&token=${encodeURIComponent(token)}`;
}

export default function Studies() {
  const [studies, setStudies] = useState(null);
  const [error, setError] = useState("");
  useEffect(() => {
    api("studies")
      .then((d) => setStudies(d.studies))
      .catch((e) => setError(e.message));
  }, []);
  if (error) return <div className="message error">{error}</div>;
  if (studies === null) return <div className="muted">Looking for studies...</div>;
  return (
    <div data-testid="studies">
      {!studies.length && (
        <div className="muted">
          No study in this folder. Run <code>pasim study STUDY.yaml --out DIR</code> inside it.
        </div>
      )}
      <ul className="studies">
        {studies.map((s) => (
          <li key={s.path}>
            <div>
              <strong>{s.path}</strong>
              <span className="muted">
                {" "}
                {s.study_file} · {s.runs_finished} run{s.runs_finished === 1 ? "" : "s"} finished
              </span>
            </div>
            {s.report ? (
              <a href={reportUrl(s.path)} target="_blank" rel="noopener noreferrer" data-testid="study-report">
                Open the report of {s.path}
              </a>
            ) : (
              <span className="muted">no report yet (the study is still running, or stopped)</span>
            )}
          </li>
        ))}
      </ul>
    </div>
  );
}
