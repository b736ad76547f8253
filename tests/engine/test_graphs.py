"""Every graph shipped in graphs/ loads, validates and round-trips."""

from __future__ import annotations

import pytest

from pasim_graph import load
from pasim_graph.graphfile import dumps, parse, read

from ..conftest import GRAPHS

#: Study files (``format: pasim-study/1``) live beside the graphs; tests/study/test_study_files.py
#: checks them.
FILES = sorted(p for p in GRAPHS.glob("*.yaml") if not p.name.endswith("_study.yaml"))


def test_there_are_graphs():
    assert FILES


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_graph_validates_and_round_trips(path):
    # The file as written (load() also derives the truth block's sector from the scan's, so
    # its text carries what a run used: see test_load_adds_only_the_derived_truth_sector).
    graph = load_text(path.read_text())
    text = graph.text()
    # load -> save -> load is identical, and the shipped file is already canonical.
    assert dumps(parse(text)) == text
    assert text == path.read_text()
    assert load_text(text).to_json()["blocks"] == graph.to_json()["blocks"]


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_load_adds_only_the_derived_truth_sector(path):
    as_written = load_text(path.read_text()).to_json()["blocks"]
    loaded = load(path).to_json()["blocks"]
    for name, block in loaded.items():
        extra = {k: v for k, v in block["params"].items() if as_written[name]["params"].get(k) != v}
        if extra:
            assert block["type"].startswith("truth.") and set(extra) == {
                "azimuth_start_deg",
                "azimuth_stop_deg",
            }, (name, extra)


def load_text(text):
    from pasim_graph.graph import validate

    return validate(parse(text))


def test_read_reports_unreadable(tmp_path):
    spec = read(tmp_path / "missing.yaml")
    assert spec.problems and "cannot read" in spec.problems[0].message


def test_block_reference_is_written_from_the_declarations():
    """docs/blocks.md is what `pasim blocks --markdown` writes for the library's blocks."""
    from pasim_graph.block_reference import blocks_markdown
    from pasim_graph.registry import all_blocks

    library = {n: c for n, c in all_blocks().items() if c.__module__.startswith("pasim_blocks")}
    expected = blocks_markdown(library)
    assert (GRAPHS.parent / "docs" / "blocks.md").read_text() == expected, (
        "docs/blocks.md is stale: run `pasim blocks --markdown > docs/blocks.md`"
    )
