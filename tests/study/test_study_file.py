"""The study file is checked whole before any run: every problem named at once, exit 2.

Each broken study differs from the tiny study of ``fixtures/study`` by one fault; the
message must name it with the study file's line, and no folder may be created.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from pasim_blocks.study.model import parse_study
from pasim_blocks.study.plan import largest_gap

from ..conftest import pasim

FIX = Path(__file__).parents[1] / "fixtures" / "study"

GOOD = """format: pasim-study/1
systems:
  - {name: narrow, graph: small_pencil.yaml}
  - {name: wide, graph: small_wide.yaml}
cases:
  - {name: convective, truth: "", sector: "280:288", elevation: 0.5}
seeds: [0]
"""


def write(tmp_path: Path, text: str) -> Path:
    for g in ("small_pencil.yaml", "small_wide.yaml"):
        shutil.copy(FIX / g, tmp_path / g)
    path = tmp_path / "study.yaml"
    path.write_text(text)
    return path


def refused(tmp_path: Path, capsys, text: str) -> str:
    study = write(tmp_path, text)
    out = tmp_path / "out"
    code, err = pasim(capsys, "study", str(study), "--out", str(out))
    assert code == 2, err
    assert "Traceback" not in err
    assert not out.exists(), "a refused study must write nothing"
    return err


def test_the_good_study_is_valid(tmp_path, capsys):
    study = write(tmp_path, GOOD)
    code, _ = pasim(capsys, "study", str(study), "--check")
    out = capsys.readouterr().out if code else ""
    assert code == 0, out


def test_unknown_graph(tmp_path, capsys):
    err = refused(tmp_path, capsys, GOOD.replace("small_wide.yaml", "no_such_graph.yaml"))
    assert "study.yaml:4" in err and "no_such_graph.yaml" in err and "wide" in err


def test_unknown_parameter_in_a_sweep(tmp_path, capsys):
    text = GOOD + "sweeps:\n  - systems: [wide]\n    values: {antenna.phase_bitz: [3, 4]}\n"
    err = refused(tmp_path, capsys, text)
    assert "study.yaml:10" in err and "phase_bitz" in err and "unknown parameter" in err


def test_unknown_parameter_in_a_system_override(tmp_path, capsys):
    text = GOOD.replace("graph: small_wide.yaml}", "graph: small_wide.yaml, set: {scan.pulsez: 4}}")
    err = refused(tmp_path, capsys, text)
    assert "study.yaml:4" in err and "pulsez" in err


def test_elevation_outside_the_truth(tmp_path, capsys):
    err = refused(tmp_path, capsys, GOOD.replace("elevation: 0.5", "elevation: 60"))
    assert "study.yaml:6" in err and "elevation 60" in err


def test_a_sector_outside_the_truth_is_measured_as_a_gap():
    # Radials every 0.5 deg over 0:90 only (a sector file): 100:120 has none of them; 10:20
    # is covered; 80:100 has 10 deg without a radial.
    az = np.arange(0.25, 90.0, 0.5)
    assert largest_gap(az, (100.0, 120.0)) == pytest.approx(20.0)
    assert largest_gap(az, (10.0, 20.0)) <= 0.5
    assert largest_gap(az, (80.0, 100.0)) == pytest.approx(10.25)
    assert largest_gap(np.arange(0.25, 360, 0.5), (350.0, 10.0)) <= 0.5  # through north


def test_duplicate_names(tmp_path, capsys):
    err = refused(tmp_path, capsys, GOOD.replace("name: wide", "name: narrow"))
    assert "study.yaml:4" in err and "duplicate system name 'narrow'" in err


def test_every_problem_is_named_at_once(tmp_path, capsys):
    text = (
        GOOD.replace("name: wide", "name: narrow")
        .replace("elevation: 0.5", "elevation: 60")
        .replace("small_pencil.yaml", "missing.yaml")
    ) + "sweeps:\n  - systems: [narrow]\n    values: {antenna.phase_bitz: [3]}\n"
    err = refused(tmp_path, capsys, text)
    assert "duplicate system name" in err
    assert "elevation 60" in err
    assert "missing.yaml" in err
    assert err.splitlines()[0].endswith("in the study:")


def test_anchors_and_deep_nesting_are_refused_by_name(tmp_path, capsys):
    err = refused(tmp_path, capsys, GOOD + "title: &a x\nreference: *a\n")
    assert "anchors and aliases" in err and "study file" in err
    deep = GOOD + "title: " + "[" * 5000 + "]" * 5000 + "\n"
    err = refused(tmp_path, capsys, deep)
    assert "nested deeper than" in err and "RecursionError" not in err


def test_unknown_keys_and_bad_values_are_located():
    study = parse_study(GOOD.replace("seeds: [0]", "seeds: [0, 0]\ncolour: red"), "s.yaml")
    text = "\n".join(str(p) for p in study.problems)
    assert "s.yaml:7" in text and "seed twice" in text
    assert "s.yaml:8" in text and "unknown key 'colour'" in text


def test_a_fifo_is_refused_as_what_it_is(tmp_path, capsys):
    import os

    fifo = tmp_path / "study.yaml"
    os.mkfifo(fifo)
    code, err = pasim(capsys, "study", str(fifo), "--check")
    assert code == 2 and "not a regular file" in err


def test_a_wide_stand_in_beam_reads_the_truth_wider():
    # A 2 m array's sidelobe-free stand-in (5 deg) is cut at 2.5 beamwidths: the truth must be
    # read at least that far past the sector (the paper study's 2 m CPPAR stopped on it).
    from pasim_blocks.study.model import read_study
    from pasim_blocks.study.plan import plan_runs

    runs, problems = plan_runs(read_study(FIX / "tiny_study.yaml"))
    assert problems == []
    (free,) = [r for r in runs if r.kind == "sidelobe_free" and r.system == "narrow"]
    for bw in (1.0, 5.2):
        g = free.graph(bw)
        (antenna,) = free.antennas
        support = g.value(antenna, "support_deg")
        assert all(g.value(t, "margin_deg") >= support for t in g.by_role("truth"))
