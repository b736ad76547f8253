"""Inputs that used to trip scripts quietly are now refused by name, promptly.

* YAML 1.1 scalars read by YAML 1.2 rules: ``1_0`` and ``4:40`` are text (refused by the
  parameter's check), not 10 and 280; ``010`` is 10, ``on``/``yes`` text.
* graph files with anchors/aliases (the "billion laughs"), deep nesting, a FIFO or
  ``/dev/zero``: refused within a second, with a bounded message.
* ``--truth ""`` (an unset shell variable), ``--sector`` together with ``--set
  scan.azimuth_start_deg``, a ``--set`` repeated: refused, naming the options.
* an output file in a folder that does not exist: one line, exit 2.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

from pasim_graph.graphfile import parse, parse_value

from ..conftest import GRAPHS, ROOT, pasim

GENERIC = str(GRAPHS / "generic_radar.yaml")


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("1_0", "1_0"),
        ("4:40", "4:40"),
        ("010", 10),
        ("on", "on"),
        ("yes", "yes"),
        ("true", True),
        ("1e-6", 1e-6),
        ("2800000000.0", 2.8e9),
        ("-3", -3),
        ("0x10", 16),
    ],
)
def test_scalars_follow_yaml_1_2(text, value):
    assert parse_value(text) == value and type(parse_value(text)) is type(value)


def test_a_yaml_1_1_number_is_refused_by_the_parameter(tmp_path, capsys):
    graph = (GRAPHS / "generic_radar.yaml").read_text().replace("pulses: 64", "pulses: 6_4")
    path = tmp_path / "g.yaml"
    path.write_text(graph)
    code, err = pasim(capsys, "validate", str(path))
    assert code == 2 and "'pulses'" in err and "6_4" in err, err


def billion_laughs() -> str:
    text = 'format: pasim-graph/1\nvariables:\n  a: &a ["lol","lol","lol","lol","lol"]\n'
    prev = "a"
    for name in "bcdefghij":
        text += f"  {name}: &{name} [" + ",".join([f"*{prev}"] * 9) + "]\n"
        prev = name
    return text + "blocks: {}\n"


@pytest.mark.parametrize("kind", ["aliases", "deep", "fifo", "dev-zero", "huge"])
def test_hostile_graph_files_are_refused_promptly(kind, tmp_path):
    path = tmp_path / "g.yaml"
    if kind == "aliases":
        path.write_text(billion_laughs())
        want = "anchors and aliases"
    elif kind == "deep":
        path.write_text("format: pasim-graph/1\nvariables:\n  a: " + "[" * 20000 + "]" * 20000)
        want = "nested deeper"
    elif kind == "fifo":
        os.mkfifo(path)
        want = "not a regular file"
    elif kind == "dev-zero":
        path = "/dev/zero"
        want = "not a regular file"
    else:
        path.write_text("format: pasim-graph/1\n" + "#" * (3 << 20) + "\n")
        want = "larger than"
    t0 = time.monotonic()
    res = subprocess.run(
        [sys.executable, "-m", "pasim_graph", "validate", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
    )
    assert time.monotonic() - t0 < 20  # the interpreter's start included; the check is ms
    assert res.returncode == 2, res.stderr
    assert want in res.stderr and "Traceback" not in res.stderr, res.stderr
    assert len(res.stderr) < 2000


def test_a_billion_laughs_is_refused_in_well_under_a_second():
    t0 = time.process_time()  # CPU time: the wall clock of a loaded machine measures others
    spec = parse(billion_laughs(), "bomb.yaml")
    assert time.process_time() - t0 < 1.0
    assert [p.message for p in spec.problems] == [
        "anchors and aliases (&name, *name) are not allowed in graph files"
    ]


@pytest.mark.parametrize(
    ("argv", "want"),
    [
        (["--truth", ""], "--truth: is empty"),
        (["--truth", "  "], "--truth: is empty"),
        (["--set", "scan.pulses=8", "--set", "scan.pulses=16"], "scan.pulses is set twice"),
        (
            ["--sector", "250:260", "--set", "scan.azimuth_start_deg=10"],
            "--sector: sets scan.azimuth_start_deg and so does --set",
        ),
        (
            ["--truth", GENERIC, "--set", "truth.path=" + GENERIC],
            "--truth: sets truth.path and so does --set",
        ),
    ],
)
def test_quiet_option_defaults_are_refused(argv, want, capsys, tmp_path):
    for command in (["validate", GENERIC], ["run", GENERIC, "--out", str(tmp_path / "s")]):
        code, err = pasim(capsys, *command, *argv)
        assert code == 2 and want in err, err
    assert not (tmp_path / "s").exists()


def test_an_output_in_a_missing_folder_is_one_line(capsys, tmp_path):
    missing = tmp_path / "no" / "such"
    for argv in (
        ["graph", GENERIC, "--out", str(missing / "g.dot")],
        ["pattern", GENERIC, "--plot", str(missing / "p.png")],
    ):
        code, err = pasim(capsys, *argv)
        assert code == 2, err
        assert f"the folder {missing} does not exist" in err and "Traceback" not in err, err
