"""The studio's model of a graph: documents, swaps, run choices, the palette and plugins."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys

import pytest

from pasim_graph import Block, Input, Output, PortType, registry
from pasim_graph.graph import GraphError, validate
from pasim_graph.graphfile import parse, read
from pasim_graph.studio import documents as docs
from pasim_graph.studio import swaps
from pasim_graph.studio.documents import RequestError

from ..conftest import FIXTURES, GRAPHS, ROOT
from .test_studio_http import Client

FILES = sorted(
    p for p in GRAPHS.glob("*.yaml") if not p.name.endswith("_study.yaml")
)  # studies: not graphs


def generic():
    return docs.doc_from_spec(read(GRAPHS / "generic_radar.yaml"))


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_documents_round_trip_every_graph_exactly(path):
    doc = docs.doc_from_spec(read(path))
    # Through JSON and back, as the page sends it: the same text, to the byte.
    doc = json.loads(json.dumps(doc))
    _, text = docs.canonical(doc, path.name)
    assert text == path.read_text()
    assert docs.check(doc, path.name)["valid"]


def test_values_keep_their_yaml_types():
    doc = generic()
    assert doc["variables"]["frequency_hz"] == "2800000000.0"  # a float, not the integer
    assert doc["blocks"]["weather"]["params"]["frequency_hz"] == "$frequency_hz"
    assert doc["blocks"]["scan"]["params"]["prt_s"] == "0.0033333333333333335"
    doc["blocks"]["tx"]["params"]["width_s"] = "'1e-6'"  # a string that looks like a number
    spec, text = docs.canonical(doc)
    assert spec.blocks["tx"].params["width_s"] == "1e-6"
    assert "width_s: '1e-6'" in text


def test_check_gives_the_engines_problems_with_the_saved_lines():
    doc = generic()
    doc["blocks"]["scan"]["params"]["pulses"] = "2.5"
    doc["blocks"]["tx"]["params"]["colour"] = "red"
    result = docs.check(doc, "g.yaml")
    spec = parse(result["text"], "g.yaml")
    with pytest.raises(GraphError) as err:
        validate(spec)
    assert [p["text"] for p in result["problems"]] == [str(p) for p in err.value.problems]
    lines = result["text"].splitlines()
    scan_line = next(i for i, line in enumerate(lines, 1) if line.startswith("  scan:"))
    assert any(p["block"] == "scan" and p["line"] == scan_line for p in result["problems"])


# -- swapping ----------------------------------------------------------------------------------


def test_swap_options_offer_exactly_the_types_that_fit():
    options = swaps.swap_options(generic(), "hpa")["options"]
    fits = sorted(o["type"] for o in options if o["fits"])
    # Every other amplifier of the library, the other pulse-to-pulse transmitter stage (the
    # power divider), and nothing else, fits the amplifier's wires.
    amplifiers = sorted(n for n in registry.names() if n.startswith("amplifier."))
    stages = ["transmitter.power_divider"]
    assert fits == sorted([a for a in amplifiers if a != "amplifier.saleh"] + stages)
    assert "amplifier.ideal" in fits
    saleh_params = {"input_backoff_db"}
    ideal = next(o for o in options if o["type"] == "amplifier.ideal")
    assert set(ideal["drops"]) == saleh_params and ideal["needs_wiring"] == []
    pencil = next(o for o in options if o["type"] == "antenna.pencil")
    assert "the wire 'tx.pulse -> hpa.pulse_in' needs an input 'pulse_in'" in " ".join(
        pencil["reasons"]
    )
    options = swaps.swap_options(generic(), "antenna")["options"]
    fit = sorted(o["type"] for o in options if o["fits"])
    assert {"antenna.cylindrical", "antenna.ideal", "antenna.planar"} <= set(fit)
    assert all(t.startswith("antenna.") for t in fit)
    assert "amplifier.saleh" in [o["type"] for o in options]  # listed, as not fitting


def test_a_port_of_the_same_name_but_another_type_is_refused_with_the_engines_diff():
    iq = PortType("iq", "complex64", ("beam", "range", "pulse", "polarization"), "sqrt(W)")
    pulse64 = PortType("pulse", "complex128", ("sample",), "sqrt(W)")

    class WidePulse(Block):
        """An amplifier whose ports are named like the library's but carry other types."""

        pulse_in = Input(iq)
        pulse = Output(pulse64)

    WidePulse.type_name = "test.wide"
    spec = docs.spec_from_doc(generic())
    reasons = swaps.fit(spec, "hpa", WidePulse)
    assert len(reasons) == 2
    text = " ".join(reasons)
    # The words of PortType.mismatch, output against input as validation compares them.
    assert "output 'pulse' of test.wide is pulse[complex128; (sample); sqrt(W)]" in text
    assert "(dtype 'complex128' vs 'dataset')" in text
    assert "(kind 'pulse' vs 'iq'; dtype 'dataset' vs 'complex64'; dims (sample) vs" in text


def test_swap_drops_what_the_new_type_lacks_and_restores_it_on_the_way_back():
    doc = generic()
    there = swaps.swap(doc, "hpa", "amplifier.ideal")
    assert there["dropped"] == {"input_backoff_db": "0.0"}
    assert there["doc"]["blocks"]["hpa"] == {"type": "amplifier.ideal", "params": {}}
    back = swaps.swap(there["doc"], "hpa", "amplifier.saleh", there["dropped"])
    assert back["restored"] == {"input_backoff_db": "0.0"}
    assert docs.canonical(back["doc"])[1] == (GRAPHS / "generic_radar.yaml").read_text()
    assert doc == generic()  # the request's document is never changed in place


def test_swap_refuses_a_misfit_with_every_reason():
    with pytest.raises(RequestError) as err:
        swaps.swap(generic(), "hpa", "antenna.pencil")
    assert err.value.status == 409
    assert len(err.value.extra["reasons"]) == 2
    assert err.value.message.startswith("cannot swap 'hpa' to antenna.pencil: its ports")


def test_a_wire_that_leaves_out_its_port_must_stay_resolvable():
    doc = generic()
    for c in doc["connections"]:
        if c["src"] == "tx" and c["dst"] == "hpa":
            c["src_port"] = c["dst_port"] = None  # "tx -> hpa"
    assert docs.check(doc, "g.yaml")["valid"]
    options = {o["type"]: o for o in swaps.swap_options(doc, "hpa")["options"]}
    assert options["amplifier.ideal"]["fits"]
    # filter.matched has two inputs: "tx -> hpa" would no longer say which one.
    reasons = " ".join(options["filter.matched"]["reasons"])
    assert "leaves out the input port, and filter.matched has 2 inputs" in reasons


# -- run choices, folder -----------------------------------------------------------------------


def test_run_choices_are_the_ladder_of_the_graph():
    choices = docs.run_choices(generic())
    labels = [level["label"] for level in choices["levels"]]
    weather = registry.get("channel.weather")
    assert labels == [label for label, _ in weather.fidelity_ladder]
    combined = next(x for x in choices["levels"] if x["label"] == "combined")
    assert combined["block"] == "weather" and combined["set"]["method"] == "combined"
    assert choices["sector"] == "240:330"


def test_run_choices_fall_back_to_the_method_choices(monkeypatch):
    weather = registry.get("channel.weather")
    monkeypatch.setattr(weather, "fidelity_ladder", ())
    labels = [x["label"] for x in docs.run_choices(generic())["levels"]]
    assert labels == list(weather.params["method"].choices)


def test_run_choices_read_the_declared_fidelity_parameter_not_its_name(monkeypatch):
    """Without a ladder, the levels are the choices of the parameter the block declares as
    its fidelity level (``Block.fidelity_param``): a parameter named ``method`` that is not
    declared gives none, a declared one of another name gives its choices."""
    weather = registry.get("channel.weather")
    monkeypatch.setattr(weather, "fidelity_ladder", ())
    monkeypatch.setattr(weather, "fidelity_param", "")
    monkeypatch.setattr(weather, "expected_level", "")
    assert docs.run_choices(generic())["levels"] == []
    monkeypatch.setattr(weather, "fidelity_param", "precision")
    choices = docs.run_choices(generic())
    assert [x["label"] for x in choices["levels"]] == list(weather.params["precision"].choices)
    assert {tuple(x["set"]) for x in choices["levels"]} == {("precision",)}
    assert choices["current"] == str(weather.params["precision"].default)


def test_folder_lists_graphs_and_finds_level2_files(tmp_path):
    shutil.copytree(GRAPHS, tmp_path / "graphs")
    data = tmp_path / "data"
    data.mkdir()
    bundled = ROOT / "blocks" / "data"
    (volume,) = bundled.glob("KLBB*_V06")  # the bundled scene: a message-31 volume
    shutil.copy(volume, data / volume.name)
    for other in bundled.glob("*.json"):  # other data files are not volumes
        shutil.copy(other, data / other.name)
    (data / "notes.txt").write_text("AR2 is not enough")
    folder = docs.Folder(tmp_path)
    assert "graphs/generic_radar.yaml" in folder.graphs()
    assert folder.truths() == [f"data/{volume.name}"]


def test_writes_are_atomic_and_keep_the_mode(tmp_path):
    target = tmp_path / "g.yaml"
    target.write_text("old\n")
    target.chmod(0o640)
    docs.write_atomic(target, "new\n")
    assert target.read_text() == "new\n"
    assert target.stat().st_mode & 0o777 == 0o640
    assert [p.name for p in tmp_path.iterdir()] == ["g.yaml"]


# -- the palette, plugins included -------------------------------------------------------------


def test_palette_lists_every_registered_type_by_subsystem():
    palette = docs.palette()
    types = [b["type"] for b in palette["blocks"]]
    assert types == sorted(registry.all_blocks())
    groups = {g["name"]: g["types"] for g in palette["groups"]}
    assert groups["amplifier"] == sorted(n for n in types if n.startswith("amplifier."))
    assert {"amplifier.ideal", "amplifier.saleh"} <= set(groups["amplifier"])
    assert {"waveform", "antenna", "channel", "receiver", "filter", "processor", "scorer",
            "scan", "truth", "scene"} <= set(groups)  # fmt: skip
    weather = next(b for b in palette["blocks"] if b["type"] == "channel.weather")
    assert weather["fidelity_ladder"] and weather["params"]
    for b in palette["blocks"]:
        cls = registry.get(b["type"])
        for side, ports in (("inputs", cls.inputs), ("outputs", cls.outputs)):
            for p in b[side]:
                # The page shows PortType.describe()'s text, and a colour for the kind.
                assert p["type"]["text"] == ports[p["name"]].type.describe()
                assert p["type"]["kind"] in palette["kind_colors"]


def test_palette_says_which_inputs_each_output_feeds():
    feeds = docs.palette()["feeds"]
    pulse = feeds["waveform.rectangular:pulse"]
    assert {"amplifier.saleh:pulse_in", "filter.matched:pulse", "filter.matched:reference"} <= set(
        pulse
    )
    assert "antenna.pencil:beams" not in pulse
    # The engine's rule, pair by pair (schemas included).
    blocks = registry.all_blocks()
    for key, targets in feeds.items():
        name, port = key.split(":")
        out = blocks[name].outputs[port].type
        for other, cls in blocks.items():
            for inp in cls.inputs.values():
                fits = not out.mismatch(inp.type)
                assert (f"{other}:{inp.name}" in targets) == fits


@pytest.fixture(scope="module")
def plugin_path(tmp_path_factory):
    """The example plugin of tests/plugin_pkg, installed into a folder of its own."""
    target = tmp_path_factory.mktemp("site")
    source = tmp_path_factory.mktemp("src") / "plugin_pkg"
    shutil.copytree(
        ROOT / "tests" / "plugin_pkg", source, ignore=shutil.ignore_patterns("build", "*.egg-info")
    )
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
         "--target", str(target), str(source)],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    return target


def test_plugins_reach_the_palette_and_broken_ones_are_named(plugin_path, tmp_path):
    shutil.copytree(GRAPHS, tmp_path / "g")
    env = {**os.environ, "PYTHONPATH": str(plugin_path), "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "pasim_graph", "studio", str(tmp_path / "g"), "--port", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT,
    )  # fmt: skip
    try:
        port = token = None
        for _ in range(20):
            m = re.search(r":(\d+)/\?token=([\w-]+)", proc.stdout.readline())
            if m:
                port, token = int(m[1]), m[2]
                break
        assert port
        status, palette = Client(port, token).get("/api/palette")
        assert status == 200
        groups = {g["name"]: g["types"] for g in palette["groups"]}
        # Every type the plugin registers that loads; the broken one is named apart.
        assert "example.attenuator" in groups["example"]
        assert "example.broken" not in groups["example"]
        broken = {b["type"]: b["error"] for b in palette["broken"]}
        assert broken["example.broken"].startswith("ImportError: this plugin needs a library")
        # The plugin's block fits between the weather channel and the receiver.
        g = Client(port, token).get("/api/graph?path=generic_radar.yaml")[1]
        doc = g["doc"]
        doc["blocks"]["radome"] = {"type": "example.attenuator", "params": {"loss_db": "3.0"}}
        doc["connections"] = [
            c for c in doc["connections"] if not (c["src"] == "weather" and c["dst"] == "receiver")
        ] + [
            {"src": "weather", "src_port": "iq", "dst": "radome", "dst_port": "iq_in"},
            {"src": "radome", "src_port": "iq", "dst": "receiver", "dst_port": "iq_in"},
        ]
        status, v = Client(port, token).post("/api/validate", {"path": "x.yaml", "doc": doc})
        assert status == 200 and v["valid"], v
    finally:
        proc.terminate()
        proc.wait(timeout=20)


def test_every_broken_fixture_opens_with_its_problems():
    folder = docs.Folder(FIXTURES / "broken")
    for rel in folder.graphs():
        g = docs.open_graph(folder, rel)
        assert g["validation"]["valid"] is False and g["validation"]["problems"], rel
        # Read-only exactly when the file format itself cannot read the whole file.
        assert g["editable"] == (not read(FIXTURES / "broken" / rel).problems), rel


def test_study_files_are_not_listed_as_graphs(tmp_path):
    """A study file (format pasim-study/1) beside graphs is not offered as a broken graph."""
    shutil.copy(GRAPHS / "generic_radar.yaml", tmp_path / "generic_radar.yaml")
    shutil.copy(GRAPHS / "paper_study.yaml", tmp_path / "paper_study.yaml")
    (tmp_path / "notes.yaml").write_text("title: not a graph, no format line\n")
    listed = docs.Folder(tmp_path).graphs()
    assert "generic_radar.yaml" in listed and "paper_study.yaml" not in listed
    assert "notes.yaml" in listed  # no format said: offered, and the editor says what is wrong
