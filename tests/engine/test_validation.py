"""Validation reports every problem at once, naming file, block, port or parameter."""

from __future__ import annotations

import json

import pytest

from pasim_graph import GraphError, load
from pasim_graph.graph import validate
from pasim_graph.graphfile import parse

from ..conftest import FIXTURES, GRAPHS, pasim_result, run_cli

BROKEN = FIXTURES / "broken"

# fixture -> words the message must contain (the culprit and what was expected)
CASES = {
    "garbage.yaml": ["garbage.yaml:", "malformed YAML"],
    "unknown_type.yaml": [
        "block 'tx'",
        "unknown block type 'waveform.rectangulr'",
        "waveform.rectangular",
    ],
    "unknown_param.yaml": ["block 'tx'", "parameter 'pulse_width'", "unknown parameter", "width_s"],
    "unknown_port.yaml": ["block 'tx'", "port 'waveform'", "pulse"],
    "incompatible.yaml": [
        "block 'antenna'",
        "port 'beams'",
        "incompatible types",
        "kind 'pulse' vs 'beams'",
    ],
    "cycle.yaml": ["cycle"],
    "bad_version.yaml": ["unknown format version 'pasim-graph/9'"],
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_broken_graph_exit_2_names_culprit(name, capsys):
    res = pasim_result(capsys, "validate", str(BROKEN / name))
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    for word in CASES[name]:
        assert word in res.stderr, (word, res.stderr)


def test_every_fixture_is_covered():
    assert {p.name for p in BROKEN.glob("*.yaml")} == set(CASES) | {"many_problems.yaml"}


def test_all_problems_reported_at_once():
    with pytest.raises(GraphError) as info:
        load(BROKEN / "many_problems.yaml")
    text = str(info.value)
    problems = info.value.problems
    assert "width_s" in text and "expected >= 1e-08" in text
    assert "unknown parameter" in text and "colour" in text
    assert "input_backoff_db" in text and "expected float, found str" in text
    assert "pulses" in text and "expected int, found float" in text
    assert "required input is not connected" in text  # mf.reference
    assert len(problems) >= 5
    # Each names the file and a line.
    assert all(p.file.endswith("many_problems.yaml") and p.line > 0 for p in problems)


def test_validate_json_lists_problems(capsys):
    res = pasim_result(capsys, "validate", str(BROKEN / "unknown_param.yaml"), "--json")
    assert res.returncode == 2
    out = json.loads(res.stdout)
    assert out["valid"] is False
    assert out["problems"][0]["block"] == "tx"


def test_validate_json_lists_blocks_and_connections(capsys):
    res = pasim_result(capsys, "validate", str(GRAPHS / "generic_radar.yaml"), "--json")
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    assert out["blocks"]["weather"]["type"] == "channel.weather"
    assert out["blocks"]["weather"]["params"]["frequency_hz"] == 2.8e9  # $variable resolved
    assert "weather.iq -> receiver.iq_in" in out["connections"]


def test_set_on_missing_block_is_an_error(capsys):
    res = pasim_result(
        capsys, "validate", str(GRAPHS / "generic_radar.yaml"), "--set", "nosuch.gain_db=3"
    )
    assert res.returncode == 2
    assert "nosuch" in res.stderr and "no block named" in res.stderr
    assert "Traceback" not in res.stderr


def test_set_out_of_bounds_value_is_an_error(capsys):
    res = pasim_result(
        capsys, "validate", str(GRAPHS / "generic_radar.yaml"), "--set", "scan.pulses=1"
    )
    assert res.returncode == 2
    assert "block 'scan'" in res.stderr and "parameter 'pulses'" in res.stderr


def test_run_with_broken_graph_exits_2_before_computing(tmp_path, capsys):
    out = tmp_path / "x.zarr"
    res = pasim_result(capsys, "run", str(BROKEN / "unknown_type.yaml"), "--out", str(out))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert not out.exists()


def test_missing_truth_file_is_named(tmp_path, capsys):
    res = pasim_result(
        capsys,
        "run",
        str(GRAPHS / "generic_radar.yaml"),
        "--truth",
        "/no/such/file",
        "--out",
        str(tmp_path / "x.zarr"),
    )
    assert res.returncode == 2
    assert "/no/such/file" in res.stderr and "no such file" in res.stderr


def test_missing_graph_file(capsys):
    res = pasim_result(capsys, "validate", "nope.yaml")
    assert res.returncode == 2 and "nope.yaml" in res.stderr and "cannot read" in res.stderr


def test_port_may_be_omitted_only_when_unique():
    text = """format: pasim-graph/1
blocks:
  tx: {type: waveform.rectangular}
  hpa: {type: amplifier.ideal}
  mf: {type: filter.matched}
  scan: {type: scan.ppi}
connections:
  - tx -> hpa
  - hpa -> mf.pulse
  - tx -> mf
"""
    with pytest.raises(GraphError) as info:
        validate(parse(text, "g.yaml"))
    msgs = [str(p) for p in info.value.problems]
    assert any("name the port" in m and "mf" in m for m in msgs)
    assert not any("hpa" in m and "name the port" in m for m in msgs)


def test_truth_file_that_is_not_level2(tmp_path, capsys):
    bogus = tmp_path / "notradar.bin"
    bogus.write_bytes(b"this is not a NEXRAD volume" * 100)
    res = pasim_result(
        capsys,
        "run",
        str(GRAPHS / "generic_radar.yaml"),
        "--truth",
        str(bogus),
        "--out",
        str(tmp_path / "x.zarr"),
    )
    assert res.returncode == 2, res.stderr
    assert "notradar.bin" in res.stderr and "Traceback" not in res.stderr
    assert not (tmp_path / "x.zarr").exists()


def test_bad_sector_is_named(capsys):
    res = pasim_result(capsys, "validate", str(GRAPHS / "generic_radar.yaml"), "--sector", "west")
    assert res.returncode == 2 and "--sector" in res.stderr and "AZ0:AZ1" in res.stderr


def test_beams_behind_the_face_are_refused_naming_the_block(tmp_path, capsys):
    """Beams behind a planar array's face cannot be steered: refused before the run (it
    failed on the first beam), naming the block (tests/engine/test_steering_checks.py)."""
    res = pasim_result(
        capsys,
        "run",
        str(GRAPHS / "planar_patch_radar.yaml"),
        "--sector",
        "90:92",
        "--out",
        str(tmp_path / "x.zarr"),
    )
    assert res.returncode == 2
    assert "block 'antenna', steering" in res.stderr and "are behind the face" in res.stderr
    assert "Traceback" not in res.stderr
    assert not (tmp_path / "x.zarr").exists()


def test_cycle_message_does_not_depend_on_the_hash_seed():
    """networkx finds cycles in set order; the message must not change with PYTHONHASHSEED
    (it did: 'a -> b -> a' or 'b -> a -> b' by seed)."""
    messages = {
        run_cli("validate", str(BROKEN / "cycle.yaml"), env={"PYTHONHASHSEED": str(h)}).stderr
        for h in (1, 2, 3, 4, 5)
    }
    assert len(messages) == 1, messages
    assert "cycle: a -> b -> a" in messages.pop()
