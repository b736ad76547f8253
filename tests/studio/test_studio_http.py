"""The studio's HTTP API: who it answers, which files it touches, and how it says no.

Every refusal must be a JSON error naming what was wrong, and must leave every file of the
served folder as it was (compared byte for byte).
"""

from __future__ import annotations

import http.client
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import time
import urllib.parse

import pytest

from pasim_graph.graphfile import dumps, read
from pasim_graph.studio.server import StudioServer

from ..conftest import FIXTURES, GRAPHS, ROOT, pasim_result, run_cli

TOKEN = "test-token-0123456789"
SERVE_BROKEN = True  # the studio serves the broken fixtures too (conftest.folder)
GENERIC_YAML = "generic_radar.yaml"


class Client:
    """A raw HTTP client: every header and byte of a request under the test's control."""

    def __init__(self, port: int, token: str | None = TOKEN):
        self.port, self.token = port, token

    def request(self, method, path, body=None, headers=None, raw=None):
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=60)
        h = {"Host": f"127.0.0.1:{self.port}"}
        if self.token:
            h["Authorization"] = f"token {self.token}"
        data = raw
        if body is not None:
            data = json.dumps(body).encode()
            h["Content-Type"] = "application/json"
        h.update(headers or {})
        h = {k: v for k, v in h.items() if v is not None}
        conn.request(method, path, body=data, headers=h)
        res = conn.getresponse()
        payload = res.read()
        conn.close()
        ctype = res.getheader("Content-Type", "")
        out = json.loads(payload) if ctype.startswith("application/json") else payload
        return res.status, out

    def get(self, path, **kw):
        return self.request("GET", path, **kw)

    def post(self, path, body=None, **kw):
        return self.request("POST", path, body=body, **kw)


@pytest.fixture
def client(studio):
    return Client(studio.port)


def raw_exchange(port, data: bytes) -> str:
    """Send bytes as they are and read the whole reply (the server closes after an error)."""
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        s.sendall(data)
        chunks = []
        while chunk := s.recv(65536):
            chunks.append(chunk)
    return b"".join(chunks).decode()


def snapshot(root):
    """Every file under ``root`` with its bytes (temporary files included)."""
    return {
        p.relative_to(root).as_posix(): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and not p.is_symlink()
    }


def generic_doc(client):
    status, g = client.get("/api/graph?path=generic_radar.yaml")
    assert status == 200, g
    return g


# -- who is answered ---------------------------------------------------------------------------


def test_requests_without_the_token_are_refused(studio):
    for token in (None, "wrong-token"):
        c = Client(studio.port, token)
        for path in (
            "/",
            "/api/session",
            "/api/graph?path=generic_radar.yaml",
            "/assets/studio.js",
        ):
            status, body = c.get(path)
            assert status == 403, path
            assert "missing or wrong token" in body["error"]
    status, body = Client(studio.port, None).get(f"/api/session?token={TOKEN}")
    assert status == 200 and body["graphs"]


def test_the_page_and_its_assets_carry_the_token(studio, client):
    status, html = client.get("/")
    assert status == 200
    html = html.decode()
    assets = re.findall(r'(?:src|href)="\./(assets/[^"]+)"', html)
    assert assets and all(a.endswith(f"?token={TOKEN}") for a in assets)
    tokenless = Client(studio.port, None)
    for a in assets:
        status, body = tokenless.get("/" + a)
        assert status == 200 and len(body) > 1000, a
    # The licences of what the bundle contains ship with it.
    status, text = client.get("/THIRD_PARTY_LICENSES.txt")
    assert status == 200 and b"@xyflow/react" in text and b"MIT" in text


def test_foreign_host_is_refused(studio, client):
    for host in ("evil.example", f"evil.example:{studio.port}", "127.0.0.1:1"):
        status, body = client.get("/api/session", headers={"Host": host})
        assert status == 403, host
        assert f"Host {host!r} is not this server" in body["error"]
    # No Host at all (HTTP/1.0 style) is refused too.
    request = f"GET /api/session HTTP/1.0\r\nAuthorization: token {TOKEN}\r\n\r\n"
    reply = raw_exchange(studio.port, request.encode())
    assert reply.startswith("HTTP/1.1 403") and "Host None is not this server" in reply
    status, _ = client.get("/api/session", headers={"Host": f"localhost:{studio.port}"})
    assert status == 200


def test_foreign_origin_is_refused_and_writes_nothing(folder, client, studio):
    g = generic_doc(client)
    before = snapshot(folder)
    body = {"path": "generic_radar.yaml", "doc": g["doc"], "base_sha256": g["sha256"]}
    body["doc"]["blocks"]["hpa"]["type"] = "amplifier.ideal"
    for origin in ("http://evil.example", "null", f"http://127.0.0.1:{studio.port + 1}"):
        status, res = client.post("/api/save", body, headers={"Origin": origin})
        assert status == 403, origin
        assert "Origin" in res["error"]
    status, res = client.post("/api/save", body, headers={"Sec-Fetch-Site": "cross-site"})
    assert status == 403
    assert snapshot(folder) == before
    status, _ = client.get("/api/session", headers={"Origin": f"http://127.0.0.1:{studio.port}"})
    assert status == 200


def test_listens_on_loopback_only(studio):
    assert studio.server_address[0] == "127.0.0.1"
    with pytest.raises(TypeError):  # the address is not a parameter
        StudioServer(studio.folder.root, 0, host="0.0.0.0")  # type: ignore[call-arg]


# -- which files -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "path,status",
    [
        ("../outside.yaml", 403),
        ("broken/../../outside.yaml", 403),
        ("/etc/hosts.yaml", 403),
        ("~/outside.yaml", 403),
        ("..\\outside.yaml", 400),
        ("generic_radar.py", 400),
        ("no_such_graph.yaml", 404),
        ("link_out.yaml", 403),
    ],
)
def test_paths_outside_the_folder_are_refused(folder, tmp_path, client, path, status):
    outside = tmp_path / "outside.yaml"
    outside.write_text((GRAPHS / "generic_radar.yaml").read_text())
    (folder / "link_out.yaml").symlink_to(outside)
    before, outside_before = snapshot(folder), outside.read_bytes()
    q = urllib.parse.quote(path)
    got, body = client.get(f"/api/graph?path={q}")
    assert got == status, body
    assert repr(path) in body["error"]
    g = generic_doc(client)
    for api, extra in (
        ("/api/save", {"doc": g["doc"], "overwrite": True}),
        ("/api/layout", {"positions": {"tx": [1, 2]}}),
    ):
        if status == 404 and api == "/api/save":
            continue  # a new file inside the folder may be saved (test_save_as_a_new_file)
        got, body = client.post(api, {"path": path, **extra})
        assert got == status, (api, body)
        assert repr(path) in body["error"]
    assert snapshot(folder) == before
    assert outside.read_bytes() == outside_before


def test_graph_list_stays_inside_the_folder(folder, tmp_path, client):
    outside = tmp_path / "outside.yaml"
    outside.write_text("format: pasim-graph/1\n")
    (folder / "link_out.yaml").symlink_to(outside)
    (folder / ".hidden").mkdir()
    (folder / ".hidden" / "secret.yaml").write_text("format: pasim-graph/1\n")
    status, body = client.get("/api/graphs")
    assert status == 200
    assert "generic_radar.yaml" in body["graphs"] and "broken/cycle.yaml" in body["graphs"]
    assert "link_out.yaml" not in body["graphs"]
    assert not any(".hidden" in g for g in body["graphs"])


# -- malformed requests ------------------------------------------------------------------------


def _doc_variants(doc):
    """Documents the format cannot hold, each with a word its error message must contain."""

    def changed(f):
        d = json.loads(json.dumps(doc))
        f(d)
        return d

    return [
        ("a list", []),
        ("blocks", changed(lambda d: d.__setitem__("blocks", ["tx"]))),
        ("invalid block name", changed(lambda d: d["blocks"].__setitem__("9 bad", {"type": "x"}))),
        ("'type'", changed(lambda d: d["blocks"]["tx"].pop("type"))),
        ("as text", changed(lambda d: d["blocks"]["tx"]["params"].__setitem__("width_s", 1e-6))),
        ("unknown key", changed(lambda d: d["blocks"]["tx"].__setitem__("x", 1))),
        (
            "invalid 'src_port'",
            changed(lambda d: d["connections"][0].__setitem__("src_port", "a b")),
        ),
        ("connections", changed(lambda d: d.__setitem__("connections", "tx -> hpa"))),
        ("unknown key", changed(lambda d: d.__setitem__("layout", {}))),
    ]


def test_malformed_bodies_get_clear_errors_and_change_nothing(folder, client):
    g = generic_doc(client)
    before = snapshot(folder)
    save = {"path": "generic_radar.yaml", "base_sha256": g["sha256"], "overwrite": True}
    for word, doc in _doc_variants(g["doc"]):
        for api in ("/api/save", "/api/validate", "/api/runs", "/api/swap-options"):
            status, body = client.post(api, {**save, "doc": doc, "block": "hpa"})
            assert status == 400, (api, word, body)
            assert word in body["error"], (api, body["error"])
    cases = [
        ({"Content-Type": "application/json"}, b"{not json", 400, "malformed JSON body"),
        ({"Content-Type": "application/json"}, b"[1, 2]", 400, "expected a JSON object"),
        ({"Content-Type": "application/json"}, b"\xff\xfe", 400, "not UTF-8"),
        ({"Content-Type": "text/plain"}, b"{}", 415, "Content-Type application/json"),
        (
            {"Content-Type": "application/json", "Content-Length": str(10**9)},
            b"{}",
            413,
            "over the",
        ),
    ]
    for headers, raw, status, words in cases:
        got, body = client.request("POST", "/api/save", raw=raw, headers=headers)
        assert got == status and words in body["error"], body
    # No body length at all.
    conn = http.client.HTTPConnection("127.0.0.1", client.port)
    conn.putrequest("POST", "/api/save", skip_host=True)
    for k, v in {
        "Host": f"127.0.0.1:{client.port}",
        "Authorization": f"token {TOKEN}",
        "Content-Type": "application/json",
    }.items():
        conn.putheader(k, v)
    conn.endheaders()
    res = conn.getresponse()
    assert res.status == 411 and "Content-Length" in json.loads(res.read())["error"]
    conn.close()
    assert snapshot(folder) == before


def test_bad_values_in_requests_get_clear_errors(folder, client):
    g = generic_doc(client)
    before = snapshot(folder)
    base = {"path": "generic_radar.yaml", "doc": g["doc"]}
    checks = [
        ("/api/save", {**base, "base_sha256": g["sha256"], "overwrite": "yes"}, 400, "overwrite"),
        ("/api/save", {**base, "base_sha256": "0" * 64}, 409, "changed on disk"),
        ("/api/save", {**base}, 409, "exists"),
        ("/api/layout", {"path": "generic_radar.yaml", "positions": {"tx": [1]}}, 400, "[x, y]"),
        (
            "/api/layout",
            {"path": "generic_radar.yaml", "positions": {"tx": ["a", 2]}},
            400,
            "[x, y]",
        ),
        ("/api/layout", {"path": "generic_radar.yaml", "positions": [1, 2]}, 400, "object"),
        ("/api/swap", {**base, "block": "nope", "type": "amplifier.ideal"}, 404, "'nope'"),
        ("/api/swap", {**base, "block": "hpa", "type": "amplifier.nope"}, 400, "not a registered"),
        ("/api/swap", {**base, "block": "hpa", "type": 3}, 400, "'type'"),
        ("/api/runs", {**base, "sector": "280-290"}, 400, "AZ0:AZ1"),
        ("/api/runs", {**base, "level": "fastest"}, 400, "unknown fidelity level 'fastest'"),
        ("/api/runs", {**base, "seed": -1}, 400, "seed"),
        ("/api/runs", {**base, "seed": "1"}, 400, "seed"),
        ("/api/runs", {**base, "truth": "../outside"}, 403, "'..'"),
        ("/api/runs", {**base, "truth": "no_such_file"}, 404, "no truth file"),
        ("/api/export", {**base, "format": "png"}, 400, "svg, dot, mermaid"),
    ]
    for api, body, status, words in checks:
        got, res = client.post(api, body)
        assert got == status, (api, body.get("path"), res)
        assert words in res["error"], res["error"]
    assert snapshot(folder) == before


def test_unknown_routes_methods_and_request_lines_answer_json(client, studio):
    status, body = client.get("/api/nothing")
    assert status == 404 and "GET /api/nothing" in body["error"]
    status, body = client.post("/api/nothing", {})
    assert status == 404 and "POST /api/nothing" in body["error"]
    status, body = client.request("PUT", "/api/save", body={})
    assert status == 405 and "PUT" in body["error"]
    status, body = client.get("/api/runs/99")
    assert status == 404 and "no run '99'" in body["error"]
    status, body = client.get("/assets/../../server.py")
    assert status in (403, 404) and "error" in body
    reply = raw_exchange(studio.port, b"GARBAGE\r\n\r\n")
    assert reply.startswith("HTTP/1.1 400")
    assert reply.split("\r\n\r\n", 1)[1].startswith('{"error"')


def test_a_kept_alive_connection_survives_refusals(studio, client):
    # Refused requests leave their bodies read, so the next request on the connection parses.
    doc = generic_doc(client)["doc"]
    body = json.dumps({"path": "generic_radar.yaml", "doc": doc}).encode()
    conn = http.client.HTTPConnection("127.0.0.1", studio.port, timeout=30)
    host = {"Host": f"127.0.0.1:{studio.port}", "Content-Type": "application/json"}
    auth = {**host, "Authorization": f"token {TOKEN}"}
    steps = [
        ("POST", "/api/validate", body, host, 403),
        ("POST", "/api/validate", body, auth, 200),
        ("POST", "/api/save", b"{not json", auth, 400),
        ("POST", "/api/nothing", body, auth, 404),
        ("POST", "/api/validate", body, {**auth, "Origin": "http://evil.example"}, 403),
        ("GET", "/api/session", None, auth, 200),
    ]
    for method, path, data, headers, status in steps:
        conn.request(method, path, body=data, headers=headers)
        res = conn.getresponse()
        assert res.status == status, (method, path, res.read())
        assert "error" in json.loads(res.read()) or status == 200
    conn.close()


def test_an_internal_error_is_json_without_a_traceback(client, monkeypatch):
    from pasim_graph.studio import documents

    def boom():
        raise RuntimeError("the palette broke")

    monkeypatch.setattr(documents, "palette", boom)
    status, body = client.get("/api/palette")
    assert status == 500
    assert body == {
        "error": "internal error: RuntimeError: the palette broke (the terminal running "
        "`pasim studio` has the details)"
    }


# -- what is written ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name", sorted(p.name for p in GRAPHS.glob("*.yaml") if not p.name.endswith("_study.yaml"))
)
def test_saving_an_unchanged_graph_changes_no_byte(folder, client, name):
    before = (folder / name).read_bytes()
    status, g = client.get(f"/api/graph?path={name}")
    assert status == 200 and g["canonical"] and g["editable"]
    status, res = client.post(
        "/api/save", {"path": name, "doc": g["doc"], "base_sha256": g["sha256"]}
    )
    assert status == 200, res
    assert res["diff"] == ""
    assert (folder / name).read_bytes() == before
    assert not (folder / (name.removesuffix(".yaml") + ".layout.json")).exists()


def test_saving_writes_exactly_the_edit_canonically(folder, client):
    g = generic_doc(client)
    doc = g["doc"]
    doc["blocks"]["receiver"]["params"]["noise_figure_db"] = "3.5"
    status, res = client.post(
        "/api/save", {"path": "generic_radar.yaml", "doc": doc, "base_sha256": g["sha256"]}
    )
    assert status == 200, res
    old = (GRAPHS / "generic_radar.yaml").read_text().splitlines()
    new = (folder / "generic_radar.yaml").read_text().splitlines()
    changed = [(a, b) for a, b in zip(old, new, strict=True) if a != b]
    assert changed == [
        (
            "  receiver: {type: receiver.basic, params: {noise_figure_db: 2.7}}",
            "  receiver: {type: receiver.basic, params: {noise_figure_db: 3.5}}",
        )
    ]
    # The studio's file is what the engine's writer gives: hand-edited and saved agree.
    assert dumps(read(folder / "generic_radar.yaml")) == (folder / "generic_radar.yaml").read_text()
    leftovers = [p.name for p in folder.iterdir() if p.name.startswith(".generic_radar")]
    assert leftovers == []


def test_layout_goes_to_a_side_file_never_into_the_graph(folder, client):
    before = (folder / "generic_radar.yaml").read_bytes()
    status, res = client.post(
        "/api/layout", {"path": "generic_radar.yaml", "positions": {"tx": [10, 20.5]}}
    )
    assert status == 200 and res["path"] == "generic_radar.layout.json"
    data = json.loads((folder / "generic_radar.layout.json").read_text())
    assert data["positions"] == {"tx": [10.0, 20.5]}
    assert (folder / "generic_radar.yaml").read_bytes() == before
    status, g = client.get("/api/graph?path=generic_radar.yaml")
    assert g["layout"]["positions"]["tx"] == data["positions"]["tx"]
    assert set(g["layout"]["auto"]["positions"]) == set(g["doc"]["blocks"])


def test_save_as_a_new_file(folder, client):
    g = generic_doc(client)
    status, res = client.post("/api/save", {"path": "mine/new.yaml", "doc": g["doc"]})
    assert status == 400 and "folder does not exist" in res["error"]
    status, res = client.post("/api/save", {"path": "new.yaml", "doc": g["doc"]})
    assert status == 200
    assert (folder / "new.yaml").read_text() == (GRAPHS / "generic_radar.yaml").read_text()


# -- the engine's messages ---------------------------------------------------------------------


@pytest.mark.parametrize(
    "name", ["many_problems.yaml", "incompatible.yaml", "unknown_port.yaml", "unknown_type.yaml"]
)
def test_problems_are_the_engines_own(folder, client, name):
    status, g = client.get(f"/api/graph?path=broken/{name}")
    assert status == 200
    res = run_cli("validate", f"broken/{name}", "--json", cwd=folder)
    cli = json.loads(res.stdout)["problems"]
    keys = ("file", "line", "block", "item", "message")
    page = [{k: p[k] for k in keys} for p in g["validation"]["problems"]]
    assert page == cli
    # Edited in the page and checked again: the same list.
    status, v = client.post("/api/validate", {"path": f"broken/{name}", "doc": g["doc"]})
    assert [p["message"] for p in v["problems"]] == [p["message"] for p in cli]


def test_a_cycle_is_reported(client):
    # Not compared with a `pasim validate` process: the engine names a cycle from the block
    # networkx happens to start at, which follows Python's string hashing (PYTHONHASHSEED).
    status, g = client.get("/api/graph?path=broken/cycle.yaml")
    assert status == 200
    (problem,) = g["validation"]["problems"]
    assert problem["message"] in ("cycle: a -> b -> a", "cycle: b -> a -> b")


def test_a_graph_that_is_not_utf8_opens_read_only(folder, client):
    (folder / "latin1.yaml").write_bytes(b"format: pasim-graph/1\n# caf\xe9\nblocks: {}\n")
    status, g = client.get("/api/graph?path=latin1.yaml")
    assert status == 200 and g["editable"] is False
    (problem,) = g["validation"]["problems"]
    assert problem["file"] == "latin1.yaml" and problem["line"] == 2
    assert problem["message"].startswith("not UTF-8 text: byte 0xe9")


def test_run_sectors_follow_the_command_lines_rule(client):
    doc = generic_doc(client)["doc"]
    status, res = client.post(
        "/api/runs", {"path": "generic_radar.yaml", "doc": doc, "sector": "10:10"}
    )
    assert status == 400
    assert "the sector starts and stops at 10 deg and holds no beam" in res["error"]


def test_a_file_the_format_cannot_read_opens_read_only(client, capsys):
    status, g = client.get("/api/graph?path=broken/garbage.yaml")
    assert status == 200
    assert g["editable"] is False
    res = pasim_result(capsys, "validate", str(FIXTURES / "broken" / "garbage.yaml"), "--json")
    cli = json.loads(res.stdout)["problems"]
    assert [p["message"] for p in g["validation"]["problems"]] == [p["message"] for p in cli]


# -- runs --------------------------------------------------------------------------------------


def test_a_broken_graph_run_fails_with_the_engine_report(client):
    g = generic_doc(client)
    doc = g["doc"]
    doc["blocks"]["hpa"]["params"]["input_backoff_db"] = "99"
    status, run = client.post(
        "/api/runs", {"path": "generic_radar.yaml", "doc": doc, "sector": "280:282"}
    )
    assert status == 200, run
    assert "hpa.input_backoff_db=99" in run["label"]
    deadline = time.time() + 120
    while run["state"] not in ("done", "failed") and time.time() < deadline:
        time.sleep(0.3)
        run = client.get(f"/api/runs/{run['id']}")[1]
    assert run["state"] == "failed"
    assert "parameter 'input_backoff_db': expected <= 60.0 dB, found 99" in run["error"]


def test_a_kept_runs_folder_is_never_overwritten(folder, tmp_path):
    runs = tmp_path / "kept"
    (runs / "run1").mkdir(parents=True)
    (runs / "run1" / "graph.yaml").write_text("an earlier session's run\n")
    server = StudioServer(folder, 0, token=TOKEN, runs_dir=runs)
    server.serve_in_thread()
    try:
        c = Client(server.port)
        doc = generic_doc(c)["doc"]
        doc["blocks"]["hpa"]["params"]["input_backoff_db"] = "99"  # fails fast, in validation
        status, run = c.post("/api/runs", {"path": GENERIC_YAML, "doc": doc})
        assert status == 200 and run["id"] == "2"
        assert (runs / "run1" / "graph.yaml").read_text() == "an earlier session's run\n"
        while run["state"] not in ("done", "failed"):
            time.sleep(0.2)
            run = c.get(f"/api/runs/{run['id']}")[1]
    finally:
        server.close()
    assert (runs / "run2" / "graph.yaml").exists()  # kept: the folder was given


def test_the_command_line_serves_loopback_with_a_token(tmp_path):
    folder = tmp_path / "g"
    shutil.copytree(GRAPHS, folder)
    proc = subprocess.Popen(
        [sys.executable, "-m", "pasim_graph", "studio", str(folder), "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        url = None
        for _ in range(20):
            line = proc.stdout.readline()
            m = re.search(r"http://127\.0\.0\.1:(\d+)/\?token=([\w-]+)", line)
            if m:
                url = m
                break
        assert url, "no address printed"
        port, token = int(url[1]), url[2]
        assert len(token) >= 24
        assert Client(port, None).get("/api/session")[0] == 403
        status, s = Client(port, token).get("/api/session")
        assert status == 200 and "generic_radar.yaml" in s["graphs"]
        runs_dir = s["runs_dir"]
        assert not runs_dir.startswith(str(folder))
    finally:
        proc.terminate()
        proc.wait(timeout=20)
    # The temporary runs folder goes when the studio stops.
    assert not os.path.exists(runs_dir)


def test_the_command_line_refuses_a_missing_target(tmp_path):
    res = run_cli("studio", str(tmp_path / "nothing"), "--port", "0")
    assert res.returncode == 2 and "no such graph file or folder" in res.stderr
