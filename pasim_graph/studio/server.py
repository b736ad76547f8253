"""The studio's HTTP server: the page, a JSON API, and the checks that keep it local.

A local server that can write files is reachable from every page open in the user's
browser, so, as Jupyter's server does, it

- listens on 127.0.0.1 only;
- answers only requests that carry the session's token (``?token=`` or an
  ``Authorization: token ...`` header), printed with the address at start-up;
- refuses a ``Host`` header other than its own address (DNS rebinding) and an ``Origin``
  header other than its own (another site's page posting to it);
- serves and writes only graph files inside the served folder.

Every error is a JSON object with a message that names what was wrong (``{"error": ...}``);
none is a traceback page. Standard library only: ``HTTPServer`` with a bounded pool
(:mod:`.limits`).
"""

from __future__ import annotations

import hmac
import json
import mimetypes
import re
import secrets
import sys
import tempfile
import threading
import traceback
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

from ..interrupt import Stopped, stop_on_signals
from . import documents as docs
from . import swaps
from .documents import Folder, RequestError
from .limits import (
    IDLE_TIMEOUT,
    MAX_BODY,
    MAX_CONNECTIONS,
    REQUEST_DEADLINE,
    BoundedHTTPServer,
    dropped,
    load_json,
)
from .runs import Runs

STATIC = Path(__file__).parent / "static"
_CSP = (
    "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data: blob:; connect-src 'self'; frame-ancestors 'none'; "
    "base-uri 'none'; form-action 'none'"
)


class StudioServer(BoundedHTTPServer):
    """The studio for one folder of graphs, on 127.0.0.1; ``url`` is the address with the token.

    The server is bounded: a pool of ``max_connections`` threads serves the connections, one
    more than that is answered at once with 503, and a connection silent for
    ``idle_timeout`` seconds is closed, and so is one whose request has not all arrived
    ``request_deadline`` seconds after the server began to wait for it; so no number of
    clients (or of idle browser tabs, or of clients trickling bytes) makes it hang or grow.

    Parameters
    ----------
    folder : path
        The served folder: graphs are read and written inside it only.
    port : int
        Port on 127.0.0.1; 0 takes any free one (``port`` says which).
    graph : str, optional
        A graph of the folder to open first (relative path).
    runs_dir : path, optional
        Where runs write their stores; default a temporary folder, removed by :meth:`close`.
    token : str, optional
        The session token; default a fresh random one.
    quiet : bool
        Do not log requests to stderr.
    run_memory_bytes : int, optional
        What a run may allocate (:class:`~pasim_graph.studio.runs.Runs`); default half the
        memory available at start.
    max_connections, idle_timeout, request_deadline :
        The bounds above.
    """

    def __init__(
        self,
        folder: str | Path,
        port: int = 8765,
        *,
        graph: str | None = None,
        runs_dir: str | Path | None = None,
        token: str | None = None,
        quiet: bool = True,
        run_memory_bytes: int | None = None,
        max_connections: int = MAX_CONNECTIONS,
        idle_timeout: float = IDLE_TIMEOUT,
        request_deadline: float = REQUEST_DEADLINE,
    ):
        self.folder = Folder(folder)
        self.token = token or secrets.token_urlsafe(24)
        self.first_graph = graph
        self.quiet = quiet
        self.temporary_runs = runs_dir is None
        runs_path = Path(runs_dir or tempfile.mkdtemp(prefix="pasim-studio-runs-"))
        runs_path.mkdir(parents=True, exist_ok=True)
        self.runs = Runs(self.folder, runs_path.resolve(), memory_bytes=run_memory_bytes)
        # Loopback only, whatever the caller asks: the page can write files.
        super().__init__(
            ("127.0.0.1", port), Handler, max_connections, idle_timeout, request_deadline
        )
        self.port = int(self.server_address[1])
        self.allowed_hosts = {f"127.0.0.1:{self.port}", f"localhost:{self.port}"}
        self.allowed_origins = {f"http://{h}" for h in self.allowed_hosts}

    @property
    def url(self) -> str:
        extra = f"&graph={self.first_graph}" if self.first_graph else ""
        return f"http://127.0.0.1:{self.port}/?token={self.token}{extra}"

    def close(self) -> None:
        if getattr(self, "_serving", False):
            self.shutdown()
        self.server_close()
        self.runs.close(remove=self.temporary_runs)

    def serve_in_thread(self) -> threading.Thread:
        """Serve from a background thread (tests, notebooks); ``close()`` stops it."""
        self._serving = True
        thread = threading.Thread(target=self.serve_forever, daemon=True)
        thread.start()
        return thread


class Handler(BaseHTTPRequestHandler):
    server: StudioServer
    server_version = "pasim-studio"
    protocol_version = "HTTP/1.1"
    # A request line that cannot be parsed would otherwise count as HTTP/0.9, whose replies
    # have no status line or headers: the client would not see that it was refused.
    default_request_version = "HTTP/1.0"

    # -- plumbing ---------------------------------------------------------------------------

    def handle_one_request(self) -> None:
        self.server.request_awaited(self.connection)
        super().handle_one_request()

    def handle(self) -> None:
        try:
            super().handle()
        except (ConnectionError, TimeoutError) as exc:
            what = f" during {self.command} {urlsplit(self.path).path}" if self.command else ""
            dropped(self.client_address, exc, what)
            self.close_connection = True

    def log_message(self, format: str, *args: Any) -> None:
        # Never log the query string: it holds the token.
        if not self.server.quiet:
            path = urlsplit(self.path).path if hasattr(self, "path") else ""
            sys.stderr.write(f"studio: {self.command} {path} {args[1] if len(args) > 1 else ''}\n")

    def send_error(self, code: int, message: str | None = None, explain: str | None = None) -> None:
        """The base class's errors (bad request line, unknown method) as JSON too."""
        try:
            text = message or HTTPStatus(code).phrase
        except ValueError:
            text = message or "error"
        self._json(code, {"error": text})

    def _send(
        self, status: int, body: bytes, content_type: str, headers: dict[str, str] | None = None
    ) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Referrer-Policy", "no-referrer")
        self.send_header("X-Frame-Options", "DENY")
        for k, v in (headers or {}).items():
            self.send_header(k, v)
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _json(self, status: int, data: Any) -> None:
        body = json.dumps(data, default=str, allow_nan=False).encode()
        self._send(status, body, "application/json; charset=utf-8")

    def do_GET(self) -> None:
        self._handle("GET")

    def do_POST(self) -> None:
        self._handle("POST")

    def do_HEAD(self) -> None:
        self._handle("HEAD")

    def _refuse_method(self) -> None:
        self._handle(self.command)

    do_PUT = do_DELETE = do_PATCH = do_OPTIONS = _refuse_method

    # -- the checks every request passes ----------------------------------------------------

    def _check_origin(self) -> None:
        host = self.headers.get("Host")
        if host not in self.server.allowed_hosts:
            raise RequestError(
                403,
                f"refused: Host {host!r} is not this server "
                f"(expected {' or '.join(sorted(self.server.allowed_hosts))})",
            )
        origin = self.headers.get("Origin")
        if origin is not None and origin not in self.server.allowed_origins:
            raise RequestError(
                403, f"refused: Origin {origin!r} is not this server; the studio answers its page"
            )
        if self.headers.get("Sec-Fetch-Site") == "cross-site":
            raise RequestError(403, "refused: a cross-site request")

    def _check_token(self, query: dict[str, list[str]]) -> None:
        given = (query.get("token") or [""])[0]
        auth = self.headers.get("Authorization", "")
        if not given and auth.lower().startswith("token "):
            given = auth[6:].strip()
        if not given or not hmac.compare_digest(given.encode(), self.server.token.encode()):
            raise RequestError(
                403,
                "refused: missing or wrong token; open the address `pasim studio` printed "
                "(it ends in ?token=...)",
            )

    def _body(self) -> dict[str, Any]:
        ctype = self.headers.get("Content-Type", "")
        if ctype.split(";")[0].strip().lower() != "application/json":
            raise RequestError(
                415, f"expected a JSON body (Content-Type application/json), found {ctype!r}"
            )
        length = self.headers.get("Content-Length")
        if length is None or not length.isdigit():
            raise RequestError(411, "a request body needs a Content-Length")
        n = int(length)
        if n > MAX_BODY:
            raise RequestError(413, f"request body of {n} bytes is over the {MAX_BODY} limit")
        raw = self.rfile.read(n)
        self._body_read = True
        self.server.request_received(self.connection)
        if len(raw) < n:
            raise RequestError(400, f"the body ended after {len(raw)} of {n} bytes")
        return load_json(raw)

    # -- routing ----------------------------------------------------------------------------

    def _handle(self, method: str) -> None:
        # One handler serves every request of a kept-alive connection.
        self._body_read = False
        if method != "POST":
            self.server.request_received(self.connection)
        try:
            self._check_origin()
            url = urlsplit(self.path)
            query = parse_qs(url.query)
            self._check_token(query)
            if method not in ("GET", "HEAD", "POST"):
                raise RequestError(405, f"method {method} is not used by the studio")
            self._route(method, url.path, query)
        except RequestError as exc:
            self._drain()
            self._json(exc.status, {"error": exc.message, **exc.extra})
        except (ConnectionError, TimeoutError):
            raise  # the client went away: nothing to answer (handle() logs one line)
        except Exception as exc:
            self._drain()
            traceback.print_exc(file=sys.stderr)
            self._json(
                500,
                {
                    "error": f"internal error: {type(exc).__name__}: {exc} "
                    "(the terminal running `pasim studio` has the details)"
                },
            )

    def _drain(self) -> None:
        """Read an unread body so that the connection stays usable for the next request."""
        if self.command == "POST" and not self._body_read:
            length = self.headers.get("Content-Length", "")
            if length.isdigit() and int(length) <= MAX_BODY:
                self.rfile.read(int(length))
                self.server.request_received(self.connection)
            else:
                self.close_connection = True

    def _route(self, method: str, path: str, query: dict[str, list[str]]) -> None:
        if method in ("GET", "HEAD"):
            if path in ("/", "/index.html"):
                return self._index()
            if path.startswith("/assets/") or path == "/THIRD_PARTY_LICENSES.txt":
                return self._static(path)
            get = _GET.get(path)
            if get is not None:
                return self._json(200, get(self, query))
            if path == "/studies/report":
                return self._study_report(query)
            m = re.fullmatch(r"/api/runs/(\w+)/images/(\w+)\.png", path)
            if m:
                png = self.server.runs.image(m[1], m[2]).read_bytes()
                return self._send(200, png, "image/png")
            m = re.fullmatch(r"/api/runs/(\w+)", path)
            if m:
                return self._json(200, self.server.runs.get(m[1]).to_json())
            raise RequestError(404, f"no such page or API: GET {path}")
        post = _POST.get(path)
        m = re.fullmatch(r"/api/runs/(\w+)/(cancel|label)", path)
        if post is None and m is None:
            raise RequestError(404, f"no such API: POST {path}")
        body = self._body()
        if m and m[2] == "label":
            return self._json(200, self.server.runs.rename(m[1], body.get("label")).to_json())
        if m:
            return self._json(200, self.server.runs.cancel(m[1]).to_json())
        assert post is not None
        return self._json(200, post(self, body))

    # -- the page ---------------------------------------------------------------------------

    def _index(self) -> None:
        index = STATIC / "index.html"
        if not index.exists():
            raise RequestError(500, f"the studio's page is missing from the package ({index})")
        html = index.read_text()
        # The page's own files need the token too; the bundle is built with fixed names.
        token = self.server.token
        html = re.sub(
            r'(src|href)="\./(assets/[^"?]+)"', lambda m: f'{m[1]}="./{m[2]}?token={token}"', html
        )
        self._send(
            200, html.encode(), "text/html; charset=utf-8", {"Content-Security-Policy": _CSP}
        )

    def _static(self, path: str) -> None:
        root = STATIC.resolve()
        full = (root / path.lstrip("/")).resolve()
        if not full.is_relative_to(root) or not full.is_file():
            raise RequestError(404, f"no such file: {path}")
        ctype = mimetypes.guess_type(full.name)[0] or "application/octet-stream"
        if full.suffix == ".js":
            ctype = "text/javascript"
        if ctype.startswith("text/"):
            ctype += "; charset=utf-8"
        self._send(200, full.read_bytes(), ctype)

    def _study_report(self, query: dict[str, list[str]]) -> None:
        """A study's report (``?path=STUDY_FOLDER``), to open in its own tab.

        Served sandboxed: the page is a file from the folder, and its address carries the
        token, so it gets an opaque origin, no scripts (the study's report has none) and
        nothing fetched from elsewhere (its figures are embedded).
        """
        report = self.server.folder.study_report((query.get("path") or [""])[0])
        policy = "sandbox; default-src 'none'; img-src data:; style-src 'unsafe-inline'"
        self._send(
            200,
            report.read_bytes(),
            "text/html; charset=utf-8",
            {"Content-Security-Policy": policy},
        )

    # -- the API ----------------------------------------------------------------------------

    def api_session(self, query: dict[str, list[str]]) -> dict[str, Any]:
        from .. import __version__

        return {
            "folder": str(self.server.folder.root),
            "graphs": self.server.folder.graphs(),
            "first_graph": self.server.first_graph,
            "version": __version__,
            "runs_dir": str(self.server.runs.dir),
            "runs_kept": not self.server.temporary_runs,
        }

    def api_graphs(self, query: dict[str, list[str]]) -> dict[str, Any]:
        return {"graphs": self.server.folder.graphs()}

    def api_graph(self, query: dict[str, list[str]]) -> dict[str, Any]:
        rel = (query.get("path") or [""])[0]
        return docs.open_graph(self.server.folder, rel)

    def api_palette(self, query: dict[str, list[str]]) -> dict[str, Any]:
        return docs.palette()

    def api_truths(self, query: dict[str, list[str]]) -> dict[str, Any]:
        return {"truths": self.server.folder.truths()}

    def api_studies(self, query: dict[str, list[str]]) -> dict[str, Any]:
        return {"studies": self.server.folder.studies()}

    def api_runs(self, query: dict[str, list[str]]) -> dict[str, Any]:
        runs = self.server.runs.runs.values()
        return {"runs": [r.to_json() | {"log": [], "text": ""} for r in runs]}

    def api_compare(self, query: dict[str, list[str]]) -> dict[str, Any]:
        a, b = (query.get("a") or [""])[0], (query.get("b") or [""])[0]
        if not a or not b:
            raise RequestError(400, "compare needs two runs: ?a=ID&b=ID")
        return self.server.runs.compare(a, b)

    def _path_of(self, body: dict[str, Any]) -> str:
        rel = body.get("path") or "untitled.yaml"
        if not isinstance(rel, str):
            raise RequestError(400, "'path' must be text")
        return rel

    def post_validate(self, body: dict[str, Any]) -> dict[str, Any]:
        rel = self._path_of(body)
        try:
            old = docs.read_text(self.server.folder.resolve(rel, must_exist=False))
        except RequestError:
            old = ""
        result = docs.check(body.get("doc"), rel, old, self.server.folder)
        result["diff"] = docs.diff(old, result["text"], rel)
        result["changed"] = old != result["text"]
        result["run_choices"] = docs.run_choices(body.get("doc"))
        return result

    def post_swap_options(self, body: dict[str, Any]) -> dict[str, Any]:
        return swaps.swap_options(body.get("doc"), str(body.get("block")))

    def post_swap(self, body: dict[str, Any]) -> dict[str, Any]:
        rel = self._path_of(body)
        out = swaps.swap(
            body.get("doc"), str(body.get("block")), body.get("type"), body.get("stash")
        )
        out["validation"] = docs.check(out["doc"], rel, folder=self.server.folder)
        return out

    def post_save(self, body: dict[str, Any]) -> dict[str, Any]:
        rel = body.get("path")
        out = docs.save(
            self.server.folder,
            rel,
            body.get("doc"),
            body.get("base_sha256"),
            body.get("overwrite", False),
        )
        out["validation"] = docs.check(body.get("doc"), str(rel), folder=self.server.folder)
        return out

    def post_layout(self, body: dict[str, Any]) -> dict[str, Any]:
        return docs.write_layout(self.server.folder, body.get("path"), body.get("positions"))

    def post_layout_auto(self, body: dict[str, Any]) -> dict[str, Any]:
        from ..graph_export import auto_layout_json, view

        return auto_layout_json(view(docs.spec_from_doc(body.get("doc"))))

    def post_export(self, body: dict[str, Any]) -> dict[str, Any]:
        from ..graph_export import FORMATS, view

        fmt = body.get("format")
        if fmt not in FORMATS:
            raise RequestError(400, f"format {fmt!r}: expected one of {', '.join(FORMATS)}")
        rel = self._path_of(body)
        spec = docs.spec_from_doc(body.get("doc"), rel)
        g = view(spec, Path(rel).stem)
        if fmt == "svg" and isinstance(body.get("positions"), dict):
            from ..graph_export import to_svg

            # The picture as arranged on the canvas, when the page sends its positions.
            return {"format": fmt, "text": to_svg(g, _positions(body["positions"], g.nodes))}
        return {"format": fmt, "text": FORMATS[fmt](g)}

    def post_runs(self, body: dict[str, Any]) -> dict[str, Any]:
        return self.server.runs.start(body).to_json()


def _positions(raw: dict[str, Any], nodes: dict[str, Any]) -> dict[str, tuple[float, float]] | None:
    """Positions from the page for every block, or None (then the automatic layout is used)."""
    out = {}
    for name in nodes:
        xy = raw.get(name)
        if not (
            isinstance(xy, list) and len(xy) == 2 and all(isinstance(v, (int, float)) for v in xy)
        ):
            return None
        out[name] = (float(xy[0]), float(xy[1]))
    return out


_GET = {
    "/api/session": Handler.api_session,
    "/api/graphs": Handler.api_graphs,
    "/api/graph": Handler.api_graph,
    "/api/palette": Handler.api_palette,
    "/api/truths": Handler.api_truths,
    "/api/studies": Handler.api_studies,
    "/api/runs": Handler.api_runs,
    "/api/compare": Handler.api_compare,
}
_POST = {
    "/api/validate": Handler.post_validate,
    "/api/swap-options": Handler.post_swap_options,
    "/api/swap": Handler.post_swap,
    "/api/save": Handler.post_save,
    "/api/layout": Handler.post_layout,
    "/api/layout/auto": Handler.post_layout_auto,
    "/api/export": Handler.post_export,
    "/api/runs": Handler.post_runs,
}


def serve(
    target: str | Path | None = None,
    port: int = 8765,
    runs_dir: str | Path | None = None,
    open_browser: bool = False,
) -> int:
    """Serve the studio until interrupted or terminated (``pasim studio``).

    Parameters
    ----------
    target : path, optional
        A graph file (its folder is served and it opens first) or a folder; default ``.``.
    port : int
        Port on 127.0.0.1 (0: any free one).
    runs_dir : path, optional
        Keep the runs' stores here; by default they go to a temporary folder removed at exit.
    open_browser : bool
        Open the page in the default browser.

    Returns
    -------
    int
        The exit code: 0, or 2 when the target does not exist or the port is taken.
    """
    target = Path(target or ".")
    if not target.exists():
        print(f"error: {target}: no such graph file or folder", file=sys.stderr)
        return 2
    graph = None
    folder = target
    if target.is_file():
        folder = target.parent
        graph = target.name
        if not graph.endswith(docs.GRAPH_SUFFIXES):
            print(f"error: {target}: not a graph file (.yaml or .yml)", file=sys.stderr)
            return 2
    try:
        server = StudioServer(folder, port, graph=graph, runs_dir=runs_dir, quiet=True)
    except OSError as exc:
        print(
            f"error: cannot listen on 127.0.0.1:{port}: {exc.strerror or exc} "
            "(pass --port N, or --port 0 for any free port)",
            file=sys.stderr,
        )
        return 2
    where = "kept" if runs_dir else "deleted when the studio stops; keep them with --runs DIR"
    try:
        # Signals are taken before the address is printed: whoever reads it may stop us.
        with stop_on_signals():
            print(f"PASIM-graph studio serving the graphs in {server.folder.root}", flush=True)
            print(f"runs are written to {server.runs.dir} ({where})", flush=True)
            print(
                f"open this address in a browser (Ctrl-C stops the studio):\n\n    {server.url}\n",
                flush=True,
            )
            if open_browser:
                import webbrowser

                webbrowser.open(server.url)
            server.serve_forever()
    except Stopped as exc:
        # Runs in progress are cancelled and their stores removed with the studio's folder
        # (or kept, under --runs DIR, for --resume).
        kept = f"; runs kept in {server.runs.dir}" if not server.temporary_runs else ""
        print(f"studio stopped by {exc}{kept}", file=sys.stderr)
        return exc.exit_code
    finally:
        server.server_close()
        server.runs.close(remove=server.temporary_runs)
    return 0
