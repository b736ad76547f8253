"""What the studio's server keeps for a page that reloads, and how runs are named.

The page asks the server again after a reload: the runs with their names and results
(`GET /api/runs`), the graph's own sector and fidelity level for the run form. Runs of
different systems never share a default name, and a run can be renamed.
"""

from __future__ import annotations

import shutil
import time

import pytest

from pasim_graph.studio.server import StudioServer

from ..conftest import GRAPHS
from .test_studio_http import GENERIC_YAML, TOKEN, Client, generic_doc


@pytest.fixture
def client(tmp_path):
    shutil.copytree(GRAPHS, tmp_path / "graphs")
    server = StudioServer(tmp_path / "graphs", 0, token=TOKEN, runs_dir=tmp_path / "runs")
    server.serve_in_thread()
    yield Client(server.port)
    server.close()


def finish(client, run):
    deadline = time.time() + 120
    while run["state"] not in ("done", "failed", "cancelled") and time.time() < deadline:
        time.sleep(0.3)
        run = client.get(f"/api/runs/{run['id']}")[1]
    return run


def test_the_run_form_gets_the_graphs_own_sector_and_level(client):
    """The form used to default to 280:290 at `combined`; the graph runs 240:330 with the
    weather channel's default method (covariance), and the server says so."""
    g = generic_doc(client)
    assert g["run_choices"]["sector"] == "240:330"
    assert g["run_choices"]["current"] == "covariance"
    doc = g["doc"]
    doc["blocks"]["weather"]["params"].update(
        {"method": "combined", "support_db": "-40.0", "precision": "float32"}
    )
    status, v = client.post("/api/validate", {"path": GENERIC_YAML, "doc": doc})
    assert status == 200 and v["run_choices"]["current"] == "combined-40dB"


def test_runs_of_different_systems_never_share_a_name_and_can_be_renamed(client):
    """Two unsaved graphs used to get the same label. The second names what differs from
    the first; a name typed by the user is kept by the server (what a reload shows)."""
    doc = generic_doc(client)["doc"]
    names = []
    for backoff in ("98", "99"):  # both fail fast, in validation
        doc["blocks"]["hpa"]["params"]["input_backoff_db"] = backoff
        status, run = client.post("/api/runs", {"path": "new_system.yaml", "doc": doc})
        assert status == 200, run
        names.append(finish(client, run)["label"])
    assert names[0] == "run 1: new_system.yaml with unsaved edits"
    assert names[1].startswith("run 2: new_system.yaml with unsaved edits, unlike run 1: ")
    assert "hpa.input_backoff_db=99" in names[1]
    status, run = client.post("/api/runs/1/label", {"label": "  Saleh at 98 dB  "})
    assert status == 200 and run["label"] == "Saleh at 98 dB"
    listed = {r["id"]: r["label"] for r in client.get("/api/runs")[1]["runs"]}
    assert listed == {"1": "Saleh at 98 dB", "2": names[1]}
    for bad in ("", "x" * 201, "two\nlines", 7):
        status, out = client.post("/api/runs/1/label", {"label": bad})
        assert status == 400 and "'label'" in out["error"]
    status, out = client.post("/api/runs/9/label", {"label": "x"})
    assert status == 404
