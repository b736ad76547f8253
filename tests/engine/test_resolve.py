"""One graph-resolution path: ``pasim validate --json``, ``pasim_graph.load`` and
``pasim_graph.graph.resolve`` give the same graph, derived truth sector included."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pasim_graph import GraphError, load
from pasim_graph.cli import main
from pasim_graph.graph import parse_sector, resolve

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"
#: The graphs (study files, ``*_study.yaml``, live beside them).
FILES = sorted(p for p in GRAPHS.glob("*.yaml") if not p.name.endswith("_study.yaml"))


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_cli_and_python_resolve_the_same_graph(path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["validate", "--json", str(path)]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed == json.loads(json.dumps({"valid": True, **load(path).to_json()}))


def test_the_truth_reads_the_scans_sector_through_load() -> None:
    graph = load(GRAPHS / "generic_radar.yaml")
    (truth,) = graph.by_role("truth")
    (scan,) = graph.by_role("scan")
    for key in ("azimuth_start_deg", "azimuth_stop_deg"):
        assert graph.value(truth, key) == graph.value(scan, key) is not None


def test_choices_as_the_command_line_gives_them() -> None:
    graph, overrides = resolve(
        GRAPHS / "generic_radar.yaml", settings=["weather.method=expected"], sector="350:10"
    )
    (truth,) = graph.by_role("truth")
    assert graph.value("weather", "method") == "expected"
    assert graph.value(truth, "azimuth_start_deg") == 350.0
    assert graph.value(truth, "azimuth_stop_deg") == 10.0
    assert overrides["weather.method"] == "expected"


def test_every_bad_choice_is_reported_at_once_under_the_callers_names() -> None:
    with pytest.raises(GraphError) as exc:
        resolve(
            GRAPHS / "generic_radar.yaml",
            settings=["nonsense"],
            sector="10:10",
            labels={"set": "--set", "sector": "--sector"},
        )
    text = exc.value.report()
    assert "--set nonsense" in text and "--sector 10:10" in text


def test_parse_sector_is_the_engines() -> None:
    assert parse_sector("-10:10") == ((350.0, 10.0), None)
    assert parse_sector("0:360") == ((0.0, 360.0), None)
    assert parse_sector("a:b")[0] is None
