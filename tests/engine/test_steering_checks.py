"""A planar array's face held against every beam of the scan before any run (issue #34).

A sector behind the face used to pass validation and a study's ``--check`` and fail only on
the first beam, after the set-up (``ValueError: steering direction az=90.4 ... is not in
front of the face``); now validation, ``pasim run`` and ``pasim study`` refuse it at once,
naming the block, the beams behind the face and what the face reaches, and write nothing.
"""

from __future__ import annotations

import pytest

from tests.conftest import GRAPHS, pasim, pasim_out

BEHIND = "azimuth 90.5 to 194.5 deg at elevation 0.5 deg, are behind the face"
REACH = "azimuth 195.0 to 15.0 deg (clockwise) at elevation 0.5 deg"


def test_validate_names_the_beams_behind_the_face(capsys):
    code, err = pasim(capsys, "validate", str(GRAPHS / "atd_radar.yaml"), "--sector", "90:210")
    assert code == 2
    lines = [line for line in err.splitlines() if "steering" in line]
    assert len(lines) == 1
    assert "block 'antenna'" in lines[0]
    assert "105 of the scan's 120 beams" in lines[0] and BEHIND in lines[0]
    assert "normal at azimuth 285 deg" in lines[0] and REACH in lines[0]


def test_a_sector_across_the_edge_names_only_the_beams_behind(capsys):
    code, err = pasim(capsys, "validate", str(GRAPHS / "atd_radar.yaml"), "--sector", "200:20")
    assert code == 2
    assert "5 of the scan's 180 beams, azimuth 15.5 to 19.5 deg" in err


def test_a_tilted_face_reaches_higher_beams_behind_its_normal(capsys):
    # Tilted up 60 deg, the face sees a beam at 80 deg elevation on its back azimuth.
    graph = str(GRAPHS / "uniform_planar.yaml")
    tilt = "antenna.face_tilt_deg=60"
    code, _ = pasim(capsys, "validate", graph, "--sector", "95:115", "--set", tilt)
    assert code == 2
    code, _ = pasim(
        capsys, "validate", graph, "--sector", "95:115", "--set", tilt, "--set",
        "scan.elevation_deg=80",
    )  # fmt: skip
    assert code == 0


def test_a_run_behind_the_face_writes_nothing(capsys, tmp_path):
    out = tmp_path / "behind.zarr"
    code, _, err = pasim_out(
        capsys, "run", str(GRAPHS / "uniform_planar.yaml"), "--sector", "90:150", "--out", str(out)
    )
    assert code == 2
    assert "block 'antenna'" in err and "60 of the scan's 60 beams" in err
    assert "Traceback" not in err and "failed on beams" not in err
    assert not out.exists()


def test_a_run_in_front_of_the_face_still_runs(capsys, tmp_path):
    out = tmp_path / "front.zarr"
    code, stdout, _ = pasim_out(
        capsys, "run", str(GRAPHS / "uniform_planar.yaml"), "--sector", "283:285", "--out", str(out)
    )
    assert code == 0 and (out / "sweep_0").is_dir()
    assert "DBZH" in stdout


def test_the_executor_checks_the_beams_it_runs():
    """The beams as run (aligned to the truth) are checked again before any chunk: a graph
    changed after validation is refused by the executor itself."""
    from pasim_graph.executor import LocalExecutor
    from pasim_graph.graph import resolve
    from pasim_graph.steering import SteeringError

    graph = resolve(GRAPHS / "uniform_planar.yaml", sector="283:285").graph
    graph.params["antenna"]["face_azimuth_deg"] = 105.0
    executor = LocalExecutor(graph)
    ran = []
    executor.run_chunk = lambda *a: ran.append(a)  # type: ignore[method-assign]
    with pytest.raises(SteeringError, match=r"block 'antenna'.*2 of the scan's 2 beams"):
        executor.run()
    assert not ran


def _study(tmp_path, sector: str):
    path = tmp_path / "study.yaml"
    path.write_text(
        "format: pasim-study/1\n"
        "title: behind the face\n"
        "reference: atd\n"
        "systems:\n"
        f"  - {{name: atd, graph: {GRAPHS / 'atd_radar.yaml'}}}\n"
        "cases:\n"
        f'  - {{name: east, truth: "", sector: "{sector}", elevation: 0.5}}\n'
        "seeds: [0]\n"
    )
    return path


def test_a_study_behind_the_face_is_refused_by_check_and_before_any_run(capsys, tmp_path):
    study = _study(tmp_path, "90:210")
    code, _, err = pasim_out(capsys, "study", str(study), "--check")
    assert code == 2
    lines = [line for line in err.splitlines() if "steering" in line]
    # One line for the system and case, though its estimate, expected and calibration runs
    # each validate the same graph.
    assert len(lines) == 1
    assert "system 'atd', case 'east'" in lines[0] and "block 'antenna'" in lines[0]
    assert BEHIND in lines[0] and REACH in lines[0]
    out = tmp_path / "out"
    code, _, err = pasim_out(capsys, "study", str(study), "--out", str(out))
    assert code == 2 and "steering" in err
    assert not out.exists()


def test_a_study_in_front_of_the_face_passes_check(capsys, tmp_path):
    code, stdout, _ = pasim_out(capsys, "study", str(_study(tmp_path, "240:330")), "--check")
    assert code == 0 and "valid" in stdout
