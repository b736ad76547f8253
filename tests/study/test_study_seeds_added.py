"""Seeds added to a finished study (blocks/study/runner.py ``added_seeds``): ``--resume`` with
the study file's seeds extended keeps the runs it has and runs only the new seeds' runs; any
other change to the study is still refused. The three-seed study begun that way is checked
value for value against the same study begun with three seeds (slow), and its kept runs
untouched (tests/study/test_study_intervals.py's fixture is such a study)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from ..conftest import FIXTURES, pasim, tiny_study_file


def take(
    tmp_path: Path,
    seeds: str,
    *,
    resume: bool = True,
    edit: tuple[str, str] = ("", ""),
    graphs: Path = FIXTURES / "study",
) -> dict:
    """``take_folder`` of ``tmp_path/out`` for the tiny study with ``seeds`` (no run): a study
    begun there (``resume=False``), or its resume with the study file changed."""
    from pasim_blocks.study.integrity import study_inputs
    from pasim_blocks.study.model import read_study
    from pasim_blocks.study.plan import plan_runs
    from pasim_blocks.study.runner import take_folder

    folder = tmp_path / ("second" if resume else "first")
    study = read_study(tiny_study_file(folder, seeds, edit, graphs))
    runs, problems = plan_runs(study)
    assert not problems, problems
    return take_folder(tmp_path / "out", study, resume, study_inputs(study, runs))


def begun(tmp_path: Path, seeds: str, graphs: Path = FIXTURES / "study") -> tuple[Path, dict]:
    """A study folder begun (its manifest written, no run) with ``seeds``."""
    return tmp_path / "out", take(tmp_path, seeds, resume=False, graphs=graphs)


def test_added_seeds_are_taken_and_recorded(tmp_path, capsys):
    out, first = begun(tmp_path, "[0]")
    state = take(tmp_path, "[0, 1, 2]")
    assert "seeds 1, 2 added to the study" in capsys.readouterr().err
    saved = json.loads((out / "pasim-study.json").read_text())
    assert saved["study_digest"] == state["study_digest"] != first["study_digest"]
    assert "seeds: [0, 1, 2]" in saved["study_text"]
    assert saved["seeds_added"] == [{"seeds": [1, 2], "from": first["study_text"]}]
    take(tmp_path, "[0, 1, 2]")  # the same study again: an ordinary resume
    assert "added" not in capsys.readouterr().err


@pytest.mark.parametrize(
    ("seeds", "edit"),
    [
        ("[1, 2]", ("", "")),  # seed 0 dropped: its runs would be kept but not scored
        ("[0, 1]", ("280:288", "280:290")),  # another sector as well
        ("[0, 1]", ("name: wide", "name: broad")),  # a system renamed as well
        ("[0, 1]", ("title: two", "title: three")),  # the title as well
    ],
)
def test_any_other_change_is_refused_and_nothing_is_written(tmp_path, seeds, edit):
    from pasim_blocks.study.runner import StudyError

    out, _ = begun(tmp_path, "[0]")
    before = (out / "pasim-study.json").read_bytes()
    with pytest.raises(StudyError, match="changed since this folder's study began"):
        take(tmp_path, seeds, edit=edit)
    assert (out / "pasim-study.json").read_bytes() == before


def test_added_seeds_with_a_changed_graph_are_refused(tmp_path):
    # The study file's own change is its seeds; a graph it reads changed as well is named.
    from pasim_blocks.study.runner import StudyError

    graphs = tmp_path / "graphs"
    shutil.copytree(FIXTURES / "study", graphs)
    begun(tmp_path, "[0]", graphs)
    graph = graphs / "small_wide.yaml"
    graph.write_text(graph.read_text() + "\n# edited\n")
    with pytest.raises(StudyError, match=r"graph file of system 'wide'.*changed"):
        take(tmp_path, "[0, 1]", graphs=graphs)


@pytest.mark.slow
def test_a_study_with_seeds_added_is_the_study_begun_with_them(tiny_study, tmp_path, capsys):
    """Independent computation: the same three-seed study run from nothing. Every score
    (each system, field and statistic, the intervals and the paired comparisons) is the same;
    the seed-0 stores of the extended study are the one-seed study's, untouched."""
    extended, scratch = tmp_path / "extended", tmp_path / "scratch"
    shutil.copytree(tiny_study, extended / "out")
    kept = {p: p.stat().st_mtime_ns for p in (extended / "out" / "runs").rglob("*") if p.is_file()}

    def study(folder: Path, *flags: str) -> None:
        study_path = tiny_study_file(folder, "[0, 1, 2]")
        code, err = pasim(capsys, "study", str(study_path), "--out", str(folder / "out"), *flags)
        assert code == 0, err

    study(extended, "--resume", "--no-report")
    assert all(p.stat().st_mtime_ns == t for p, t in kept.items()), "a kept run was rewritten"
    study(scratch, "--no-report")
    a = json.loads((extended / "out" / "scores.json").read_text())
    b = json.loads((scratch / "out" / "scores.json").read_text())
    assert a.keys() == b.keys()
    for key in a:
        if key != "_study":
            assert a[key] == b[key], key
    assert a["_study"]["pairs"] == b["_study"]["pairs"]
    assert a["_study"]["rankings"] == b["_study"]["rankings"]
