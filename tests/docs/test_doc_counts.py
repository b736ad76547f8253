"""Counts and command lines the docs state about the code, against the code (issue 37).

- Every usage line of the pages (a fenced block whose lines start with ``pasim COMMAND``)
  names only options that command's parser has, with the choices it offers.
- The studies' sizes the pages give (runs, systems, the estimate) are what ``pasim study``
  prints before it plans (``blocks/study/sizing.py``).
- The README's count of tests is the suite's (``slow``: collecting the suite imports every
  test module).

The counts are read from the pages' sentences, never copied here.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys

import pytest

from ..conftest import FIXTURES, GRAPHS, ROOT
from .pages import PAGES, fences

DOCS = ROOT / "docs"


def _words(page) -> str:
    return " ".join(page.read_text().split())


def usage_lines() -> list[tuple[str, str]]:
    """(where, line) for every usage line of the pages, continuation lines joined and the
    comment after it left off."""
    out = []
    for page in PAGES:
        for fence in fences(page):
            lines = fence.text.splitlines()
            if fence.lang or not lines or not lines[0].startswith("pasim "):
                continue
            joined: list[str] = []
            for line in lines:
                if line.startswith("pasim "):
                    joined.append(line)
                elif line.startswith(" ") and joined:
                    joined[-1] += " " + line.strip()
            out += [(fence.where, line.split("  #")[0]) for line in joined]
    return out


def sub_parser(command: str) -> argparse.ArgumentParser:
    from pasim_graph.cli import parser

    top = parser([command])
    (sub,) = [a for a in top._actions if isinstance(a, argparse._SubParsersAction)]
    return sub.choices[command]


@pytest.mark.parametrize(
    ("where", "line"),
    [pytest.param(w, line, id=f"{w}-{line.split()[1]}") for w, line in usage_lines()],
)
def test_a_usage_line_names_the_commands_options(where, line):
    """The command exists, and every option the line names is one of its own."""
    command = line.split()[1]
    options = sub_parser(command)._option_string_actions
    named = re.findall(r"(?<![\w-])(--[a-z][\w-]*)(?:[ =]([\w]+(?:\|[\w]+)+))?", line)
    for option, alternatives in named:
        assert option in options, f"{where}: pasim {command} has no {option}"
        choices = options[option].choices
        if alternatives and choices is not None:
            assert set(alternatives.split("|")) == set(choices), (where, option, choices)


def test_the_usage_lines_cover_the_commands():
    """The usage lines found: the README's list names the commands of the command line."""
    commands = {line.split()[1] for _, line in usage_lines()}
    assert {"run", "validate", "score", "study", "pattern", "waveform", "spectrum"} <= commands


def _size(study):
    from pasim_blocks.study.sizing import duration, size_study

    size = size_study(study)
    return size.runs, duration(size.seconds)


def test_the_shipped_studies_sizes():
    """docs/study.md: "the volume study's 38 runs are estimated at 6 min ...; the paper
    study's 35 runs at 5 min, the bits study's 24 at 3 min"."""
    from pasim_blocks.study.model import read_study

    claims = re.findall(
        r"the (\w+) study's (\d+)(?: runs)?(?: are estimated)? at (\d+ min)",
        _words(DOCS / "study.md"),
    )
    assert {name for name, _, _ in claims} == {"volume", "paper", "bits"}
    for name, runs, estimate in claims:
        assert _size(read_study(GRAPHS / f"{name}_study.yaml")) == (int(runs), estimate), name


def test_the_scaling_guides_studies():
    """docs/scaling.md: "The tiny study of the tests (2 systems, 8 runs of 8 beams x 8
    pulses)" and "graphs/paper_study.yaml with seeds: [0] (four systems on 240:330, 19
    runs)"."""
    from pasim_blocks.study.model import read_study

    from pasim_graph.graphfile import read

    words = _words(DOCS / "scaling.md")
    systems, runs, beams, pulses = map(
        int,
        re.search(
            r"The tiny study of the tests \((\d+) systems, (\d+) runs of (\d+) beams x "
            r"(\d+) pulses\)",
            words,
        ).groups(),
    )
    tiny = read_study(FIXTURES / "study" / "tiny_study.yaml")
    assert (len(tiny.systems), _size(tiny)[0]) == (systems, runs)
    (case,) = tiny.cases
    assert case.sector[1] - case.sector[0] == beams  # one beam a degree in both graphs
    for system in tiny.systems:
        scan = read(system.graph).blocks["scan"].params
        assert (scan["pulses"], scan.get("beam_spacing_deg", 1.0)) == (pulses, 1.0)
    seeds, count, sector, runs = re.search(
        r"`graphs/paper_study\.yaml` with `seeds: \[([\d, ]+)\]` \((\w+) systems on ([\d:]+), "
        r"(\d+) runs\)",
        words,
    ).groups()
    paper = read_study(GRAPHS / "paper_study.yaml")
    paper.seeds = [int(s) for s in seeds.split(",")]
    assert _size(paper)[0] == int(runs)
    assert len(paper.systems) == ["one", "two", "three", "four", "five"].index(count) + 1
    assert [c.sector for c in paper.cases] == [tuple(map(float, sector.split(":")))]


@pytest.mark.slow  # collecting the suite imports every test module: 20-40 s of CPU
def test_the_readmes_count_of_tests():
    """The README's "About 1,710 tests": the default suite's count, within 2 %."""
    stated = int(
        re.search(r"About ([\d,]+) tests\b", _words(ROOT / "README.md")).group(1).replace(",", "")
    )
    res = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", "-n0"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=900,
    )
    found = re.search(r"^(\d+)(?:/\d+)? tests? collected", res.stdout, re.M)
    assert found, res.stdout[-2000:] + res.stderr[-2000:]
    assert abs(int(found.group(1)) - stated) <= 0.02 * stated, found.group(0)
