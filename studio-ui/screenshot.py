"""Take the screenshots of docs/studio.md: the generic radar loaded, run, and compared.

Run from the top of the repository, in the project's environment, with Debian's chromium:

    python studio-ui/screenshot.py

It serves a temporary copy of graphs/, drives the page as a user would (run a 10 deg sector,
swap the antenna, run again, compare) at 1280 x 800 and writes docs/studio.png,
docs/studio-compare.png and docs/studio-difference.png.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from playwright.sync_api import sync_playwright

from pasim_graph.studio.server import StudioServer

ROOT = Path(__file__).resolve().parents[1]
ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "graphs"
        shutil.copytree(ROOT / "graphs", folder)
        server = StudioServer(folder, 0, token="docs", runs_dir=Path(tmp) / "runs")
        server.serve_in_thread()
        try:
            with sync_playwright() as p:
                # A laptop's window: the page's first view is made for it.
                browser = p.chromium.launch(
                    executable_path="/usr/bin/chromium", args=ARGS, headless=True
                )
                context = browser.new_context(viewport={"width": 1280, "height": 800})
                page = context.new_page()
                page.goto(f"http://127.0.0.1:{server.port}/?token=docs&graph=generic_radar.yaml")
                page.wait_for_selector("[data-testid=block-hpa]")
                page.click("[data-testid=tab-run]")
                page.fill("[data-testid=run-sector]", "280:290")
                page.select_option("[data-testid=run-level]", "combined")
                page.click("[data-testid=run-button]")
                page.wait_for_selector("[data-testid=run-1].done", timeout=180_000)
                page.click("[data-testid=block-hpa] .block-name")
                page.wait_for_timeout(1500)
                page.screenshot(path=str(ROOT / "docs" / "studio.png"))

                page.click(".react-flow__controls-fitview")
                page.wait_for_timeout(500)
                page.click("[data-testid=block-antenna] .block-name")
                page.wait_for_selector(
                    "[data-testid=swap-select] option >> nth=1", state="attached"
                )
                page.select_option("[data-testid=swap-select]", "antenna.ideal")
                page.click("[data-testid=swap-button]")
                page.wait_for_selector("[data-testid=swap-message]")
                page.click("[data-testid=tab-run]")
                page.click("[data-testid=run-button]")
                page.wait_for_selector("[data-testid=run-2].done", timeout=180_000)
                page.check("[data-testid=compare-1]")
                page.check("[data-testid=compare-2]")
                page.wait_for_selector("[data-testid=compare-table]")
                page.wait_for_timeout(1500)
                page.click("[data-testid=toggle-left]")
                page.wait_for_timeout(800)
                page.screenshot(path=str(ROOT / "docs" / "studio-compare.png"))
                page.click("[data-testid=view-diff]")
                page.wait_for_timeout(1500)
                page.screenshot(path=str(ROOT / "docs" / "studio-difference.png"))
                context.close()
                browser.close()
        finally:
            server.close()


if __name__ == "__main__":
    main()
