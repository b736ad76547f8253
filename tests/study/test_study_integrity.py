"""A study's results are the study's own: no setting silently dropped, no stale or foreign
store kept.

- A sweep or ``set:`` of a parameter the case sets itself (the scan's sector and elevation,
  the truth's file and cut) is refused at ``--check`` and before any run, by name.
- ``--resume`` refuses a folder whose inputs changed since it began (a system's graph file,
  a file a block reads through a ``path`` parameter, the package version).
- A store found in a run's place is kept only when its own attributes say it is that run.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import zarr

from ..conftest import pasim

FIX = Path(__file__).parents[1] / "fixtures" / "study"
GRAPHS = ("small_pencil.yaml", "small_wide.yaml")

STUDY = """format: pasim-study/1
systems:
  - {name: narrow, graph: small_pencil.yaml}
  - {name: wide, graph: small_wide.yaml}
cases:
  - {name: convective, truth: "", sector: "280:282", elevation: 0.5}
seeds: [0]
"""


def write(folder: Path, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for g in GRAPHS:
        shutil.copy(FIX / g, folder / g)
    path = folder / "study.yaml"
    path.write_text(text)
    return path


# ---- 1. a sweep or set: of a case's own setting ------------------------------------------


@pytest.mark.parametrize(
    ("extra", "system_line", "given", "key"),
    [
        # the sweep: scan.elevation_deg [0.5, 3.0] on a case at 0.5 deg
        (
            "sweeps:\n  - {systems: [wide], values: {scan.elevation_deg: [0.5, 3.0]}}\n",
            "wide",
            "sweep scan.elevation_deg",
            "elevation 0.5",
        ),
        ("", "narrow", "set scan.azimuth_start_deg", "sector 280:282"),
        ("", "narrow", "set truth.elevation_deg", "elevation 0.5"),
    ],
)
def test_a_sweep_or_set_of_a_case_setting_is_refused(
    tmp_path, capsys, extra, system_line, given, key
):
    text = STUDY + extra
    if given.startswith("set "):
        param = given.split()[1]
        text = text.replace(
            "graph: small_pencil.yaml}", f"graph: small_pencil.yaml, set: {{{param}: 3.0}}}}"
        )
    study = write(tmp_path, text)
    line = next(i for i, t in enumerate(text.splitlines(), 1) if given.split()[1] in t)
    for argv in (["--check"], ["--out", str(tmp_path / "out")]):
        code, err = pasim(capsys, "study", str(study), *argv)
        assert code == 2, err
        assert "Traceback" not in err
        (problem,) = [e for e in err.splitlines() if "collides" in e]
        assert f"{study}:{line}:" in problem, problem
        assert f"system '{system_line}', {given}" in problem, problem
        assert f"case 'convective' ({key})" in problem, problem
    assert not (tmp_path / "out").exists(), "a refused study writes nothing"


def test_a_sweep_of_another_parameter_is_still_valid(tmp_path, capsys):
    # The refusal is of the case's keys only: a truth or scan parameter the case leaves alone
    # may be swept.
    extra = "sweeps:\n  - {systems: [wide], values: {scan.pulses: [8, 16]}}\n"
    code, err = pasim(capsys, "study", str(write(tmp_path, STUDY + extra)), "--check")
    assert code == 0, err


# ---- 2. --resume after an input changed ----------------------------------------------------


def test_a_changed_file_read_through_a_path_parameter_is_named(tmp_path):
    """A waveform file (read by a ``path`` parameter) changed at the same path: the study's
    inputs differ, and ``--resume`` refuses the folder naming it."""
    from pasim_blocks.study.integrity import study_inputs
    from pasim_blocks.study.model import read_study
    from pasim_blocks.study.plan import plan_runs
    from pasim_blocks.study.runner import StudyError, take_folder

    pulse = tmp_path / "pulse.npz"
    np.savez(pulse, envelope=np.ones(32, complex), sample_rate_hz=2e7)
    study_path = write(tmp_path, STUDY)
    graph = tmp_path / "small_pencil.yaml"
    graph.write_text(
        graph.read_text().replace(
            "{type: waveform.rectangular, params: {width_s: 1.6e-06}}",
            f"{{type: waveform.file, params: {{path: {pulse}}}}}",
        )
    )
    study = read_study(study_path)
    runs, problems = plan_runs(study)
    assert not problems, problems
    before = study_inputs(study, runs)
    assert before["files"]["tx.path of system 'narrow'"]["path"] == str(pulse), before
    out = tmp_path / "out"
    take_folder(out, study, False, before)
    take_folder(out, study, True, study_inputs(study, runs))  # unchanged: resumes
    np.savez(pulse, envelope=np.ones(40, complex), sample_rate_hz=2e7)
    with pytest.raises(StudyError, match=r"tx\.path of system 'narrow'.*changed"):
        take_folder(out, study, True, study_inputs(study, runs))


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """The two-system study, run once: its folder beside its study and graph files."""
    root = tmp_path_factory.mktemp("integrity") / "study"
    study = write(root, STUDY)
    from pasim_graph.cli import main

    # (scores only: the report is tests/study/test_study_report.py's subject)
    assert main(["study", str(study), "--out", str(root / "out"), "--no-report"]) == 0
    return root


def copy_of(finished: Path, tmp_path: Path) -> tuple[Path, Path]:
    root = tmp_path / "study"
    shutil.copytree(finished, root)
    return root / "study.yaml", root / "out"


def _mtimes(folder: Path) -> dict[str, int]:
    return {str(p): p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


def test_resume_refuses_a_study_whose_graph_file_changed(finished, tmp_path, capsys):
    """The issue's case: beamwidth 1 -> 3 deg in a system's graph and one store removed; a
    resume would mix a 3 deg estimate with 1 deg references."""
    study, out = copy_of(finished, tmp_path)
    graph = study.parent / "small_pencil.yaml"
    text = graph.read_text()
    assert "beamwidth_deg: 1.0" in text
    graph.write_text(text.replace("beamwidth_deg: 1.0", "beamwidth_deg: 3.0"))
    gone = out / "runs/narrow/convective/-/estimate-seed0.zarr"
    shutil.rmtree(gone)
    before = _mtimes(out)
    code, err = pasim(capsys, "study", str(study), "--out", str(out), "--resume")
    assert code == 2, err
    (line,) = [e for e in err.splitlines() if e.startswith("error:")]
    assert "graph file of system 'narrow'" in line and "small_pencil.yaml" in line, line
    assert "system 'wide'" not in line, "only the changed file is named"
    assert not gone.exists() and _mtimes(out) == before, "nothing run, nothing touched"


# ---- 3. a store in a run's place that is another run's -------------------------------------


def test_another_systems_store_in_a_runs_place_is_refused(finished, tmp_path, capsys):
    """The issue's case: wide's estimate copied into narrow's place was kept, and narrow's
    DBZH std became wide's."""
    study, out = copy_of(finished, tmp_path)
    place = out / "runs/narrow/convective/-/estimate-seed0.zarr"
    shutil.rmtree(place)
    shutil.copytree(out / "runs/wide/convective/-/estimate-seed0.zarr", place)
    before = _mtimes(out)
    code, err = pasim(capsys, "study", str(study), "--out", str(out), "--resume")
    assert code == 2, err
    (line,) = [e for e in err.splitlines() if e.startswith("error:")]
    assert str(place) in line and "study_system is 'wide'" in line and "'narrow'" in line, line
    assert _mtimes(out) == before, "the store is left as it is, nothing else run"


def test_a_store_with_another_run_key_is_refused(finished, tmp_path, capsys):
    """The right names, but written from another graph or program: its run key differs."""
    study, out = copy_of(finished, tmp_path)
    place = out / "runs/wide/convective/-/sidelobe_free-ref.zarr"
    root = zarr.open_group(str(place), mode="r+")
    key = root.attrs["pasim_run_key"]
    root.attrs["pasim_run_key"] = "0" * len(key)
    code, err = pasim(capsys, "study", str(study), "--out", str(out), "--resume")
    assert code == 2, err
    (line,) = [e for e in err.splitlines() if e.startswith("error:")]
    assert str(place) in line and "run key" in line and key in line, line
