"""The studio page in a real headless Chromium (Debian's, driven by Playwright for Python).

Each test serves a fresh copy of graphs/ and works on graphs/generic_radar.yaml as a user
would: clicks, selects, types, drags. What the page shows is checked against the engine
(messages, scores) and what it writes against the files on disk.
"""

from __future__ import annotations

import difflib
import json
from pathlib import Path

import pytest

from pasim_graph import registry
from pasim_graph.graph import GraphError, validate
from pasim_graph.graphfile import dumps, read
from pasim_graph.store import open_volume, summarize

CHROMIUM = Path("/usr/bin/chromium")
if not CHROMIUM.exists():
    pytest.skip(
        "Debian's chromium is not installed (/usr/bin/chromium): `apt-get install chromium` "
        "(.ci/run does it) to run the studio's browser tests",
        allow_module_level=True,
    )
sync_api = pytest.importorskip(
    "playwright.sync_api", reason="Playwright for Python is missing: pip install -e '.[test]'"
)

# Without the background-networking flags, this closed network refuses Chromium's connections.
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
TOKEN = "browser-test-token"
GENERIC = "generic_radar.yaml"
RUN_TIMEOUT_MS = 180_000


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    with sync_api.sync_playwright() as p:
        context = p.chromium.launch_persistent_context(
            str(tmp_path_factory.mktemp("chromium-profile")),
            executable_path=str(CHROMIUM),
            args=ARGS,
            headless=True,
            viewport={"width": 1600, "height": 1000},
        )
        context.set_default_timeout(20_000)
        yield context
        context.close()


@pytest.fixture
def page(browser, studio):
    page = browser.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(f"http://127.0.0.1:{studio.port}/?token={TOKEN}&graph={GENERIC}")
    page.wait_for_selector("[data-testid=block-hpa]")
    settle(page)
    yield page
    page.close()
    assert not errors, errors  # no uncaught exception in the page


def settle(page):
    """Wait until the canvas stops moving (the page fits the graph into view after loading):
    a click aimed at a block while it moves lands beside it."""
    page.wait_for_function(
        """() => {
            const v = document.querySelector('.react-flow__viewport');
            const t = v ? v.style.transform : null;
            const still = t !== null && t === window.__studioTestTransform;
            window.__studioTestTransform = t;
            return still;
        }""",
        polling=300,
    )


def select_block(page, name):
    # On a loaded machine the canvas can still be fitting the graph into view when the click
    # comes, so the click lands beside the block: click again once the canvas is still (the
    # selection itself is what the tests check, so a third miss still fails).
    for attempt in range(3):
        page.click(f"[data-testid=block-{name}] .block-name")
        try:
            page.wait_for_selector(f"[data-testid=block-name][value={name}]", timeout=8000)
            break
        except sync_api.TimeoutError:
            if attempt == 2:
                raise
            settle(page)
    try:
        page.wait_for_selector("[data-testid=swap-select] option >> nth=1", state="attached")
    except sync_api.TimeoutError:
        notice = page.locator("[data-testid=notice]")
        said = notice.inner_text() if notice.count() else "no notice"
        raise AssertionError(f"the types for '{name}' never came ({said})") from None


def swap(page, block, to):
    select_block(page, block)
    page.select_option("[data-testid=swap-select]", to)
    page.click("[data-testid=swap-button]")
    # Success and refusal both name the swap: "... 'hpa' to amplifier.ideal ...".
    page.wait_for_function(
        "(want) => document.querySelector('[data-testid=swap-message]')?.innerText.includes(want)",
        arg=f"'{block}' to {to}",
    )
    said = page.inner_text("[data-testid=swap-message]")
    if said.startswith("Swapped"):
        # The message and the redrawn block may come in separate frames.
        page.wait_for_function(
            "([b, t]) => document.querySelector(`[data-testid=block-${b}] .block-type`)"
            "?.innerText.startsWith(t)",
            arg=[block, to],
        )
    return said


def set_param(page, name, text):
    field = page.locator(f"[data-testid=param-input-{name}]")
    field.fill(text)
    field.press("Enter")


def block_type(page, name):
    return page.inner_text(f"[data-testid=block-{name}] .block-type")


def engine_problems(path, edit):
    """What the engine says about the file with one edit made (as `pasim validate` would)."""
    spec = read(path)
    edit(spec)
    try:
        validate(spec)
    except GraphError as exc:
        return [p.message for p in exc.problems]
    return []


# ---------------------------------------------------------------------------------------------


def test_palette_lists_every_registered_type_by_subsystem(page):
    for name in registry.all_blocks():
        group = name.split(".")[0]
        item = page.locator(
            f"[data-testid=palette-group-{group}] [data-testid='palette-item-{name}']"
        )
        assert item.count() == 1, name


def test_swap_saleh_to_ideal_and_back(page, folder):
    before = (folder / GENERIC).read_bytes()
    msg = swap(page, "hpa", "amplifier.ideal")
    assert msg.startswith("Swapped 'hpa' to amplifier.ideal.")
    assert "Dropped input_backoff_db = 0.0: amplifier.ideal has no such parameter" in msg
    assert block_type(page, "hpa") == "amplifier.ideal"
    assert page.inner_text("[data-testid=status]") == "valid"
    assert page.locator("[data-testid=unsaved]").count() == 1
    msg = swap(page, "hpa", "amplifier.saleh")
    assert "Restored input_backoff_db = 0.0." in msg
    assert block_type(page, "hpa") == "amplifier.saleh"
    # There and back is no change at all: nothing to save, and the file is untouched.
    page.wait_for_selector("[data-testid=unsaved]", state="detached")
    page.click("[data-testid=tab-changes]")
    assert "nothing: the file on disk is the same" in page.inner_text("[data-testid=changes]")
    assert (folder / GENERIC).read_bytes() == before


def test_incompatible_swap_is_refused_with_the_reason(page):
    select_block(page, "hpa")
    misfit = page.locator("[data-testid=swap-select] optgroup >> nth=1")
    assert "does not fit" in misfit.get_attribute("label")
    assert misfit.locator("option[value='antenna.pencil']").count() == 1
    msg = swap(page, "hpa", "antenna.pencil")
    assert msg.startswith("cannot swap 'hpa' to antenna.pencil: its ports do not fit")
    assert "the wire 'hpa.pulse -> mf.pulse' needs an output 'pulse'" in msg
    assert "the wire 'tx.pulse -> hpa.pulse_in' needs an input 'pulse_in'" in msg
    assert block_type(page, "hpa") == "amplifier.saleh"
    assert page.locator("[data-testid=unsaved]").count() == 0


def test_out_of_range_parameter_shows_the_engines_message(page, folder):
    select_block(page, "hpa")
    set_param(page, "input_backoff_db", "99")
    shown = page.wait_for_selector("[data-testid=param-problem-input_backoff_db]").inner_text()

    def edit(spec):
        spec.blocks["hpa"].params["input_backoff_db"] = 99

    (expected,) = engine_problems(folder / GENERIC, edit)
    assert shown == expected == "expected <= 60.0 dB, found 99.0"
    assert page.inner_text("[data-testid=status]") == "1 problem"
    page.click("[data-testid=tab-problems]")
    listed = page.inner_text("[data-testid=problems]")
    assert f"block 'hpa', parameter 'input_backoff_db': {expected}" in listed
    # The declaration drives the panel: units, bounds and doc.
    page.click("[data-testid=tab-inspect]")
    head = page.inner_text("[data-testid=param-input_backoff_db]")
    assert "dB" in head and "float in [0, 60]" in head
    assert "drive peak below the saturating input" in head
    # Ports with their types; a Dataset port with the variables its schema declares.
    port = page.inner_text("[data-testid=port-in-pulse_in]")
    assert "pulse[dataset; (sample); sqrt(W)]" in port
    schema = registry.get("amplifier.saleh").inputs["pulse_in"].type.schema
    summary = page.inner_text("[data-testid=port-in-pulse_in] .schema summary")
    assert summary.startswith(f"Dataset: {len(schema.variables)} variables")


def test_save_writes_exactly_the_change_and_layout_goes_aside(page, folder):
    before = (folder / GENERIC).read_text()
    select_block(page, "receiver")
    set_param(page, "noise_figure_db", "3.5")
    page.wait_for_selector("[data-testid=unsaved]")
    # Drag a block: its position goes to the side file, never into the graph.
    box = page.locator("[data-testid=block-tx] .block-header").bounding_box()
    page.mouse.move(box["x"] + 20, box["y"] + 10)
    page.mouse.down()
    page.mouse.move(box["x"] + 80, box["y"] + 90, steps=8)
    page.mouse.up()
    page.click("[data-testid=save-button]")
    page.wait_for_selector("[data-testid=unsaved]", state="detached")
    after = (folder / GENERIC).read_text()
    diff = [
        line
        for line in difflib.unified_diff(before.splitlines(), after.splitlines(), lineterm="")
        if line.startswith(("+", "-")) and not line.startswith(("+++", "---"))
    ]
    assert diff == [
        "-  receiver: {type: receiver.basic, params: {noise_figure_db: 2.7}}",
        "+  receiver: {type: receiver.basic, params: {noise_figure_db: 3.5}}",
    ]
    assert dumps(read(folder / GENERIC)) == after  # the engine's canonical form
    layout = json.loads((folder / "generic_radar.layout.json").read_text())
    assert set(layout["positions"]) == set(read(folder / GENERIC).blocks)
    assert layout["positions"]["tx"] != [0.0, 0.0]


def test_add_delete_and_rewire_through_the_engine(page, folder):
    before = (folder / GENERIC).read_bytes()
    page.click("[aria-label='add amplifier.ideal']")
    page.wait_for_selector("[data-testid=block-amplifier]")
    assert page.inner_text("[data-testid=status]") == "1 problem"
    page.click("[data-testid=tab-problems]")
    assert (
        "block 'amplifier', port 'pulse_in': required input is not connected "
        "(expects pulse[dataset; (sample); sqrt(W)])"
    ) in page.inner_text("[data-testid=problems]")
    # Undo and redo the addition, then delete the block with the keyboard.
    page.click("[data-testid=undo]")
    page.wait_for_selector("[data-testid=block-amplifier]", state="detached")
    page.click("text=Redo")
    page.wait_for_selector("[data-testid=block-amplifier]")
    page.click("[data-testid=block-amplifier] .block-name")
    page.keyboard.press("Delete")
    page.wait_for_selector("[data-testid=block-amplifier]", state="detached")
    assert page.inner_text("[data-testid=status]") == "valid"
    # Delete a wire, see what the engine says, and draw it again.
    wire = "tx.pulse -> mf.reference"
    page.locator(f"[data-testid='rf__edge-{wire}']").dispatch_event("click")
    page.keyboard.press("Delete")
    page.wait_for_selector(f"[data-testid='rf__edge-{wire}']", state="detached")
    page.click("[data-testid=tab-problems]")
    assert "block 'mf', port 'reference': required input is not connected" in page.inner_text(
        "[data-testid=problems]"
    )
    src = page.locator("[data-testid=block-tx] [data-testid=handle-out-pulse]").bounding_box()
    dst = page.locator("[data-testid=block-mf] [data-testid=handle-in-reference]").bounding_box()
    page.mouse.move(src["x"] + src["width"] / 2, src["y"] + src["height"] / 2)
    page.mouse.down()
    page.mouse.move(dst["x"] - 40, dst["y"] - 40, steps=10)
    # While dragging, the inputs a pulse can feed are marked, the others dimmed.
    reference = page.locator("[data-testid=block-mf] [data-testid=handle-in-reference]")
    beams = page.locator("[data-testid=block-antenna] [data-testid=handle-in-beams]")
    assert "hint-fits" in reference.get_attribute("class")
    assert "hint-no" in beams.get_attribute("class")
    page.mouse.move(dst["x"] + dst["width"] / 2, dst["y"] + dst["height"] / 2, steps=5)
    page.mouse.up()
    page.wait_for_selector(f"[data-testid='rf__edge-{wire}']")
    assert page.inner_text("[data-testid=status]") == "valid"
    page.wait_for_selector("[data-testid=unsaved]", state="detached")
    assert (folder / GENERIC).read_bytes() == before


def wait_run(page, run_id):
    page.wait_for_selector(f"[data-testid=run-{run_id}].done", timeout=RUN_TIMEOUT_MS)


def table(page, selector):
    rows = page.locator(f"{selector} tbody tr")
    return [rows.nth(i).locator("td").all_inner_texts() for i in range(rows.count())]


def test_run_a_sector_then_compare_before_and_after_a_swap(page, studio):
    page.click("[data-testid=tab-run]")
    page.fill("[data-testid=run-sector]", "280:285")
    page.select_option("[data-testid=run-level]", "combined")
    page.click("[data-testid=run-button]")
    page.wait_for_selector("[data-testid=run-progress-1]")  # live progress while it runs
    wait_run(page, "1")
    page.wait_for_selector("[data-testid=score-table]")
    store = studio.runs.get("1").store
    scores = summarize(open_volume(store)["sweep_0"].to_dataset())
    rows = table(page, "[data-testid=score-table]")
    assert [r[0] for r in rows] == list(scores)
    for r in rows:
        s = scores[r[0]]
        assert float(r[1]) == pytest.approx(s["bias"], rel=1e-3, abs=1e-6)
        assert float(r[2]) == pytest.approx(s["std"], rel=1e-3)
        assert int(r[3]) == s["count"]
        assert r[5] == ("pass" if s["pass"] else "fail")
    # One PPI per moment, each loaded.
    for m in ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"):
        img = page.locator(f"[data-testid=ppi-{m}] img")
        img.scroll_into_view_if_needed()
        page.wait_for_function(
            "(el) => el.complete && el.naturalWidth > 0", arg=img.element_handle()
        )

    # The same sector after swapping the antenna for one without sidelobes.
    msg = swap(page, "antenna", "antenna.ideal")
    assert "Dropped first_sidelobe_db = -32.0" in msg
    page.click("[data-testid=tab-run]")
    page.click("[data-testid=run-button]")
    wait_run(page, "2")
    assert "with antenna: antenna.ideal" in page.inner_text("[data-testid=run-2]")
    page.check("[data-testid=compare-1]")
    page.check("[data-testid=compare-2]")
    page.wait_for_selector("[data-testid=compare-table]")
    other = summarize(open_volume(studio.runs.get("2").store)["sweep_0"].to_dataset())
    for r in table(page, "[data-testid=compare-table]"):
        a, b = scores[r[0]], other[r[0]]
        assert float(r[5]) == pytest.approx(b["std"], rel=1e-3)
        assert float(r[6]) == pytest.approx(b["std"] - a["std"], rel=1e-2, abs=1e-3)
        assert float(r[3]) == pytest.approx(abs(b["bias"]) - abs(a["bias"]), rel=1e-2, abs=1e-3)
    assert any(b["std"] != a["std"] for a, b in zip(scores.values(), other.values(), strict=True))
    diff = page.inner_text("[data-testid=compare-graph-diff]")
    assert "-  antenna:  {type: antenna.pencil" in diff
    assert "+  antenna:  {type: antenna.ideal" in diff
    assert page.locator("[data-testid=compare-ppi-DBZH] img").count() == 2


def test_a_refused_path_is_shown_and_the_page_stays_usable(browser, studio):
    page = browser.new_page()
    try:
        page.goto(f"http://127.0.0.1:{studio.port}/?token={TOKEN}&graph=../outside.yaml")
        notice = page.wait_for_selector("[data-testid=notice]").inner_text()
        assert "refused path '../outside.yaml': '..' would leave the served folder" in notice
        page.select_option("[data-testid=graph-select]", GENERIC)
        page.wait_for_selector("[data-testid=block-hpa]")
        # Without the token the server answers nothing but the refusal.
        page.goto(f"http://127.0.0.1:{studio.port}/?graph={GENERIC}")
        assert "missing or wrong token" in page.inner_text("body")
    finally:
        page.close()


def test_variables_changes_tab_and_svg_export(page, folder):
    import xml.etree.ElementTree as ET

    # Select nothing (the graph): a click on the canvas's left edge, below the summary.
    page.click(".react-flow__pane", position={"x": 8, "y": 300})
    field = page.locator("[data-testid=inspector-graph] input[type=text] >> nth=0")
    assert field.input_value() == "2800000000.0"
    field.fill("2700000000.0")
    field.press("Enter")
    page.wait_for_selector("[data-testid=unsaved]")
    page.click("[data-testid=tab-changes]")
    changes = page.inner_text("[data-testid=changes]")
    assert "-  frequency_hz: 2800000000.0" in changes
    assert "+  frequency_hz: 2700000000.0" in changes
    with page.expect_download() as download:
        page.click("text=SVG")
    svg = ET.parse(download.value.path()).getroot()
    ids = {g.get("id") for g in svg.iter("{http://www.w3.org/2000/svg}g")}
    assert {f"block-{b}" for b in read(folder / GENERIC).blocks} <= ids
