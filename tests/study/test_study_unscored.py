"""A system a study leaves unscored is named at the end (issue #34): `pasim study` prints a
warning for each system that scores.json holds nothing of, with how many of its runs
finished. End to end: a study stopped after its first runs names both systems of the tiny
study (``tests/study/test_study_run.py::test_a_signalled_study_ends_with_one_line_and_resumes``).
"""

from __future__ import annotations

from pathlib import Path

from pasim_blocks.study.model import read_study
from pasim_blocks.study.plan import plan_runs
from pasim_blocks.study.runner import unscored

STUDY = Path(__file__).parents[1] / "fixtures" / "study" / "tiny_study.yaml"


def test_each_system_without_scores_is_named_with_its_finished_runs(tmp_path):
    study = read_study(str(STUDY))
    runs, problems = plan_runs(study)
    assert not problems
    per_system = {s.name: sum(r.system == s.name for r in runs) for s in study.systems}
    lines = unscored(study, runs, tmp_path, {})
    assert lines == [
        f"system '{name}' is unscored: 0 of its {n} runs finished (a case is scored once every "
        "run of the system on it has)"
        for name, n in per_system.items()
    ]
    # A system with a score is not named; the other still is.
    lines = unscored(study, runs, tmp_path, {"narrow": {"convective": {"": {}}}})
    assert len(lines) == 1 and lines[0].startswith("system 'wide' is unscored: 0 of its")
