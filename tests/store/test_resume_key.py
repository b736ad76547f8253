"""A resume never mixes two experiments: the input files' content and the program's version
are part of what must match, and the refusal says which differs."""

from __future__ import annotations

import shutil

import pasim_graph

from ..conftest import FIXTURES, GRAPHS, ROOT, pasim

TINY = str(FIXTURES / "tiny_uniform.yaml")


def test_resume_after_an_upgrade_names_both_versions(tmp_path, capsys, monkeypatch):
    out = tmp_path / "run.zarr"
    assert pasim(capsys, "run", TINY, "--out", str(out))[0] == 0
    old = pasim_graph.__version__
    monkeypatch.setattr(pasim_graph, "__version__", old + ".post1")
    code, err = pasim(capsys, "run", TINY, "--out", str(out), "--resume")
    assert code == 2, err
    assert f"pasim-graph {old} " in err and f"pasim-graph {old}.post1" in err, err
    assert "--overwrite" in err and "Traceback" not in err


def test_resume_with_the_truth_file_replaced_at_the_same_path_is_refused(tmp_path, capsys):
    truth = tmp_path / "volume"
    bundled = ROOT / "blocks" / "data" / "KLBB20160601_150025_V06"
    shutil.copyfile(bundled, truth)
    out = tmp_path / "run.zarr"
    args = ["run", str(GRAPHS / "generic_radar.yaml"), "--sector", "282:284"]
    args += ["--set", "scan.pulses=8", "--truth", str(truth), "--out", str(out)]
    assert pasim(capsys, *args)[0] == 0
    # the same bytes again: the same experiment, resumed (complete already)
    code, err = pasim(capsys, *args, "--resume")
    assert code == 0 and "already complete" in err, err
    data = bytearray(bundled.read_bytes())
    data[-1000] ^= 1  # another file at the same path (one bit is enough)
    truth.write_bytes(bytes(data))
    code, err = pasim(capsys, *args, "--resume")
    assert code == 2, err
    assert "truth.path" in err and "changed" in err and "Traceback" not in err, err
