"""``DIR/report.html`` of a study: written at the end of ``pasim study``, rebuilt by
``pasim study DIR --report-only``, self-contained (every figure an embedded PNG), its numbers
those of ``scores.json``; opened in a real Chromium where Debian's is installed.
"""

from __future__ import annotations

import base64
import json
import re
from html.parser import HTMLParser
from pathlib import Path

import pytest
from pasim_blocks.processing.scorer import REQUIREMENTS
from pasim_blocks.study.report import REPORT, sweep_figure
from pasim_blocks.study.statistics import FIELDS

from pasim_graph.cli import main

FIX = Path(__file__).parents[1] / "fixtures" / "study"
STUDY = FIX / "tiny_study.yaml"
CHROMIUM = Path("/usr/bin/chromium")
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def study(tiny_study) -> Path:
    return tiny_study


class Page(HTMLParser):
    """The tags, image sources and table cells of a page (by table class)."""

    def __init__(self) -> None:
        super().__init__()
        self.tags: list[tuple[str, dict[str, str | None]]] = []
        self.tables: dict[str, list[list[str]]] = {}
        self._table: str | None = None
        self._cell: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append((tag, a))
        if tag == "table" and a.get("class"):
            self._table = a["class"]
            self.tables[self._table] = []
        elif tag == "tr" and self._table:
            self.tables[self._table].append([])
        elif tag in ("td", "th") and self._table:
            self._cell = []

    def handle_endtag(self, tag):
        if tag == "table":
            self._table = None
        elif tag in ("td", "th") and self._table and self._cell is not None:
            self.tables[self._table][-1].append(" ".join("".join(self._cell).split()))
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def page(out: Path) -> Page:
    p = Page()
    p.feed((out / REPORT).read_text())
    return p


def test_the_report_is_self_contained(study):
    p = page(study)
    imgs = [a for t, a in p.tags if t == "img"]
    assert imgs, "no figure in the report"
    for a in imgs:
        src = a["src"] or ""
        assert src.startswith("data:image/png;base64,"), src[:60]
        assert base64.b64decode(src.split(",", 1)[1])[:8] == PNG
        assert a.get("alt")
    # Nothing fetched from anywhere: no script, no stylesheet, no external reference.
    assert not [t for t, _ in p.tags if t == "script"]
    for t, a in p.tags:
        for key in ("src", "href"):
            v = a.get(key)
            if v is not None and t != "a":
                assert v.startswith("data:"), (t, v)
    assert not re.search(r"url\(|@import|https?://", (study / REPORT).read_text())


def test_the_summary_table_says_pass_and_fail_as_scores_json_does(study):
    scores = json.loads((study / "scores.json").read_text())
    rows = page(study).tables["summary"]
    header, body = rows[0], rows[1:]
    systems = header[2:]
    assert systems == ["narrow", "wide"]
    assert [r[0].split()[0] for r in body] == [f for f in FIELDS if f in REQUIREMENTS]
    for row in body:
        name = row[0].split()[0]
        bias, std = REQUIREMENTS[name]
        assert row[1] == f"{bias} / {std}"  # paper Table 3 through the scorer
        for system, cell in zip(systems, row[2:], strict=True):
            s = scores[system]["convective"]["-"][name]
            assert cell.startswith("PASS" if s["pass"] else "FAIL")  # in words, not colour alone
            assert f"std {s['std']:.3g}" in cell
            assert f"{s['count']:,} gates" in cell
            assert f"on {s['common']['count']:,}" in cell


def test_the_budget_table_and_figure_are_there(study):
    scores = json.loads((study / "scores.json").read_text())
    p = page(study)
    rows = p.tables["budget"][1:]
    assert len(rows) == 2 * len(FIELDS)
    for row in rows:
        system, name = row[0], row[1].split()[0]
        b = scores[system]["convective"]["-"][name]["budget"]
        parts = ("main_lobe", "range", "sidelobes", "estimator_noise")
        assert row[2:6] == [f"{b[k]:.3g}" for k in parts]
        assert row[10] == max(parts, key=lambda k: b[k]).replace("_", " ")
    assert any("budget" in (a.get("alt") or "") for t, a in p.tags if t == "img")


def test_report_only_rebuilds_it_without_running(study):
    # The shared study's report is drawn by --report-only (tests/conftest.py tiny_study): after
    # its stores were written, and without touching any of them.
    before = json.loads((study.parent / "stores-before-report.json").read_text())
    assert len(before) > 100
    assert {str(p): p.stat().st_mtime_ns for p in study.rglob("*.zarr/**/*")} == before
    assert (study / REPORT).stat().st_mtime_ns > max(before.values())
    assert "wrote" in (study.parent / "report-only.err").read_text()


@pytest.mark.parametrize("what", ["missing", "not-a-study"])
def test_report_only_refuses_a_folder_that_is_no_study(tmp_path, capsys, what):
    folder = tmp_path / "x"
    if what == "not-a-study":
        folder.mkdir()
    assert main(["study", str(folder), "--report-only"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "not a folder" in err if what == "missing" else "pasim-study.json missing" in err


def test_a_sweep_draws_its_design_curve():
    def entry(std):
        return {
            "std": std,
            "std_ci": [std * 0.9, std * 1.1],
            "requirement_std": 1.0,
            "units": "dBZ",
        }

    scores = {
        "c10": {
            "conv": {f"antenna.phase_bits={b}": {"DBZH": entry(2.0 + 1.0 / b)} for b in (3, 4, 6)}
        }
    }
    fig = sweep_figure(scores, "c10", "conv")
    assert fig is not None and "antenna.phase_bits" in fig.title
    assert base64.b64decode(fig.uri.split(",", 1)[1])[:8] == PNG
    # No sweep, no curve.
    assert sweep_figure({"g": {"conv": {"-": {"DBZH": entry(2.0)}}}}, "g", "conv") is None


def open_in_chromium(report: Path) -> dict:
    """Open ``report`` in Debian's Chromium (skip without it): console errors, failed requests,
    each image's decoded width, and the rows of the summary and budget tables."""
    if not CHROMIUM.exists():
        pytest.skip("Debian's chromium is not installed (/usr/bin/chromium)")
    sync_api = pytest.importorskip("playwright.sync_api")
    errors: list[str] = []
    failed: list[str] = []
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(
            executable_path=str(CHROMIUM),
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking"],
            headless=True,
        )
        try:
            tab = browser.new_page()
            tab.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            tab.on("pageerror", lambda e: errors.append(str(e)))
            tab.on("requestfailed", lambda r: failed.append(r.url))
            tab.goto(report.resolve().as_uri(), wait_until="load")
            widths = tab.evaluate(
                "Promise.all([...document.images].map(i => i.decode().then(() => i.naturalWidth)))"
            )
            alts = tab.evaluate("[...document.images].map(i => i.alt)")
            rows = {
                t: tab.locator(f"table.{t} tbody tr").count()
                for t in ("summary", "budget", "calibration", "hardware")
            }
        finally:
            browser.close()
    return {"errors": errors, "failed": failed, "widths": widths, "alts": alts, "rows": rows}


def test_the_report_in_chromium(study):
    seen = open_in_chromium(study / REPORT)
    assert seen["errors"] == [] and seen["failed"] == []
    assert seen["widths"] and all(w > 0 for w in seen["widths"])
    assert seen["rows"]["summary"] == len(FIELDS)
    assert seen["rows"]["budget"] == 2 * len(FIELDS)
    assert sum("budget" in a for a in seen["alts"]) == 1
