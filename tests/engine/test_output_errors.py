"""Outputs a command cannot write: one line naming the file, exit 2, nothing half-written.

The reliability trial of issue 34 found tracebacks for `pasim plot --out` onto a folder or a
read-only disk, `pasim graph` and `pasim score` onto a full device, and a report left as a
temporary file on a full disk. Faults are real where this machine allows (a folder, the
`/dev/full` device) and injected at the write otherwise (a read-only disk, ENOSPC mid-file).
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import pytest

from pasim_graph import outputs
from pasim_graph.outputs import write_atomic

from ..conftest import GRAPHS, ROOT, generic_expected_run, pasim, pasim_result

GENERIC = str(GRAPHS / "generic_radar.yaml")


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """A 2-beam run of the generic radar at the fastest fidelity level."""
    return generic_expected_run(tmp_path_factory.mktemp("outputs") / "run.zarr", "280:282")


def one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_plot_onto_a_folder_is_one_line(store, tmp_path, capsys):
    res = pasim_result(capsys, "plot", str(store), "--fields", "DBZH", "--out", str(tmp_path))
    assert res.returncode == 2
    line = one_line(res.stderr)
    assert str(tmp_path) in line and "folder" in line, line


def test_graph_onto_a_full_device_is_one_line(capsys):
    res = pasim_result(capsys, "graph", GENERIC, "--format", "dot", "--out", "/dev/full")
    assert res.returncode == 2
    line = one_line(res.stderr)
    assert "/dev/full" in line and "No space left" in line, line
    assert Path("/dev/full").is_char_device()  # written to, never renamed over


def test_score_onto_a_full_standard_output_is_one_line(store):
    with open("/dev/full", "w") as full:
        res = subprocess.run(
            [sys.executable, "-m", "pasim_graph", "score", str(store)],
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
            cwd=ROOT,
            timeout=300,
        )
    assert res.returncode == 2
    assert "standard output" in one_line(res.stderr)


@pytest.mark.parametrize("fault", [errno.EROFS, errno.ENOSPC])
def test_a_disk_that_refuses_the_write_leaves_nothing(capsys, monkeypatch, store, tmp_path, fault):
    """A read-only disk refuses the temporary file; a full one fails the write mid-file: one
    line naming the output, exit 2, and no temporary file left beside it."""
    real_fsync = os.fsync

    def refuse(fd: int) -> None:
        raise OSError(fault, os.strerror(fault))

    if fault == errno.EROFS:

        def mkstemp(*args, **kwargs):
            raise OSError(fault, os.strerror(fault), str(tmp_path / "x"))

        monkeypatch.setattr(outputs.tempfile, "mkstemp", mkstemp)
    else:
        monkeypatch.setattr(outputs.os, "fsync", refuse)
    out = tmp_path / "dbzh.png"
    code, err = pasim(capsys, "plot", str(store), "--fields", "DBZH", "--out", str(out))
    monkeypatch.setattr(outputs.os, "fsync", real_fsync)
    assert code == 2
    line = one_line(err)
    assert str(out) in line and os.strerror(fault) in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_write_atomic_keeps_the_old_file_when_the_new_one_fails(monkeypatch, tmp_path):
    target = tmp_path / "report.html"
    target.write_text("old")
    target.chmod(0o640)

    def full(fd: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(outputs.os, "fsync", full)
    with pytest.raises(OSError) as caught:
        write_atomic(target, "new")
    assert caught.value.filename == str(target)
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["report.html"]
    monkeypatch.undo()
    write_atomic(target, "new")
    assert target.read_text() == "new"
    assert target.stat().st_mode & 0o777 == 0o640  # the file keeps its mode


def test_the_progress_bar_goes_to_standard_error(tmp_path, capsys):
    """dask's bar was made without ``out=``: `pasim run ... --progress > scores.txt` put
    `[####] 100% Completed` at the top of the file and showed nothing on the terminal."""
    out = tmp_path / "run.zarr"
    res = pasim_result(capsys,
        "run", GENERIC, "--sector", "280:282", "--set", "weather.method=expected",
        "--progress", "--out", str(out),
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert "Completed" in res.stderr, res.stderr
    assert "Completed" not in res.stdout and "[#" not in res.stdout, res.stdout
    assert res.stdout.lstrip().startswith("moment"), res.stdout


def test_a_note_said_by_every_run_of_a_study_is_printed_once(capsys, monkeypatch):
    """A study printed the same note once per run (9 times for 9 runs): the warnings registry
    that the "default" filter relies on is reset between runs. Each note (and warning) is
    now printed once per command, whatever resets the registry; a new command says it again."""
    import warnings

    from pasim_graph import RunNote, cli

    def fake(args) -> int:
        for _ in range(9):  # nine runs, each saying the same, each resetting the registry
            warnings.resetwarnings()
            warnings.simplefilter("default", RunNote)
            warnings.warn("the truth has no Doppler moments", RunNote, stacklevel=1)
        warnings.warn("another note", RunNote, stacklevel=1)
        return 0

    monkeypatch.setattr(cli, "cmd_blocks", fake)
    for _ in range(2):
        assert cli.main(["blocks"]) == 0
        err = capsys.readouterr().err
        assert err.count("note: the truth has no Doppler moments") == 1, err
        assert err.count("note: another note") == 1, err
