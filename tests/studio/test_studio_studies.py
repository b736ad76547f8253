"""The studio lists the studies in its folder and opens their reports (issues 22 and 28)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from pasim_graph.studio.server import StudioServer

from ..conftest import FIXTURES
from .test_studio_http import TOKEN, Client

STUDY = FIXTURES / "study"


@pytest.fixture(scope="module")
def served(tmp_path_factory, tiny_study) -> Path:
    """A folder with the tiny study's files and its finished output, as `pasim study` wrote it
    (the output shared by the study tests, copied in)."""
    root = tmp_path_factory.mktemp("served")
    for f in STUDY.iterdir():
        if f.is_file():
            shutil.copy(f, root / f.name)
    (root / "results").mkdir()
    shutil.copytree(tiny_study, root / "results" / "tiny")
    return root


@pytest.fixture
def client(served, tmp_path):
    server = StudioServer(served, 0, token=TOKEN, runs_dir=tmp_path / "runs")
    server.serve_in_thread()
    yield Client(server.port)
    server.close()


def test_the_study_is_listed_with_its_report(client, served) -> None:
    status, body = client.get("/api/studies")
    assert status == 200
    manifest = json.loads((served / "results/tiny/pasim-study.json").read_text())
    assert body["studies"] == [
        {
            "path": "results/tiny",
            "study_file": manifest["study_file"],
            "runs_finished": len(manifest["runs"]),
            "report": True,
        }
    ]
    assert body["studies"][0]["runs_finished"] > 0


def test_the_report_opens_sandboxed_with_its_bytes(client, served) -> None:
    import http.client

    conn = http.client.HTTPConnection("127.0.0.1", client.port, timeout=60)
    conn.request("GET", f"/studies/report?path=results/tiny&token={TOKEN}")
    res = conn.getresponse()
    body = res.read()
    assert res.status == 200
    assert body == (served / "results/tiny/report.html").read_bytes()
    policy = res.getheader("Content-Security-Policy", "")
    assert "sandbox" in policy and "default-src 'none'" in policy
    assert res.getheader("Content-Type", "").startswith("text/html")


@pytest.mark.parametrize(
    "path, status",
    [
        ("../outside", 403),  # leaves the folder
        ("/etc", 403),  # absolute
        ("results", 404),  # a folder without a study
        ("results/missing", 404),
    ],
)
def test_anything_but_a_study_folder_is_refused(client, path, status) -> None:
    got, body = client.get(f"/studies/report?path={path}")
    assert got == status, body


def test_a_report_without_the_token_is_refused(client) -> None:
    got, _ = Client(client.port, token=None).get("/studies/report?path=results/tiny")
    assert got in (401, 403)


def test_a_broken_manifest_or_a_fifo_is_not_listed(served, tmp_path) -> None:
    root = tmp_path / "folder"
    (root / "bad").mkdir(parents=True)
    (root / "bad" / "pasim-study.json").write_text("{not json")
    (root / "pipe").mkdir()
    os.mkfifo(root / "pipe" / "pasim-study.json")
    server = StudioServer(root, 0, token=TOKEN, runs_dir=tmp_path / "runs")
    server.serve_in_thread()
    try:
        status, body = Client(server.port).get("/api/studies")
    finally:
        server.close()
    assert status == 200 and body["studies"] == []


def test_the_studies_tab_opens_the_report_in_chromium(client) -> None:
    """In the page: the Studies tab lists the study; its link opens the report in a new tab,
    which draws its summary table and figures with no console error (the sandbox keeps it
    from the studio's API)."""
    from .test_studio_browser import ARGS, CHROMIUM, sync_api

    if sync_api is None or not CHROMIUM.exists():
        pytest.skip("Playwright or Debian's chromium is missing")
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS, headless=True)
        try:
            ctx = browser.new_context(viewport={"width": 1280, "height": 800})
            ctx.set_default_timeout(20_000)
            page = ctx.new_page()
            page.goto(f"http://127.0.0.1:{client.port}/?token={TOKEN}")
            page.get_by_test_id("tab-studies").click()
            link = page.get_by_test_id("study-report")
            link.wait_for()
            assert "results/tiny" in page.get_by_test_id("studies").inner_text()
            with ctx.expect_page() as opened:
                link.click()
            report = opened.value
            errors: list[str] = []
            report.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            report.wait_for_load_state()
            assert report.locator("table").count() > 0
            images = report.locator("img")
            assert images.count() > 0
            decoded = report.evaluate(
                "() => [...document.images].every(i => i.complete && i.naturalWidth > 0)"
            )
            assert decoded and not errors, errors
        finally:
            browser.close()
