"""Stores never destroy what this program did not write, and one run at a time writes a store.

Every refused command is checked byte for byte: the whole tree under the path it was given is
hashed before and after. Most cases run ``pasim`` in process (``pasim_graph.cli.main``); the
concurrency and crash cases run real processes, started together or killed part-way.
"""

from __future__ import annotations

import hashlib
import json
import multiprocessing
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pasim_graph.cli import main
from pasim_graph.store import (
    LOCK,
    MARKER,
    StoreError,
    is_store,
    open_store,
    open_volume,
    run_state,
    summarize,
)

from ..conftest import FIXTURES, GRAPHS, ROOT, kill_run_part_way, pasim, run_cli

TINY = str(FIXTURES / "tiny_uniform.yaml")
# 10 chunks of 2 beams, about 1 s of chunks after 2-3 s of set-up: long enough to be caught
# holding its lock or killed part-way, short enough for CI.
RACE = ["run", str(GRAPHS / "uniform_ideal.yaml"), "--set", "scan.azimuth_stop_deg=20"]
RACE += ["--chunk", "2", "--seed", "11"]


def tree_digest(root: Path) -> dict[str, str]:
    """Every entry under ``root``: files by content hash and mode, links by target, dirs."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            path = Path(dirpath) / name
            rel = str(path.relative_to(root))
            if path.is_symlink():
                out[rel] = "link -> " + os.readlink(path)
            elif path.is_dir():
                out[rel] = "dir"
            else:
                mode = oct(path.stat().st_mode & 0o7777)
                out[rel] = hashlib.sha256(path.read_bytes()).hexdigest() + " " + mode
    return out


def fill(root: Path) -> Path:
    """A directory as a user keeps one: text, binary, hidden, nested, empty, a link."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "notes.txt").write_text("do not lose me\n")
    (root / ".hidden").write_bytes(b"\x00\x01secret")
    (root / "data").mkdir()
    (root / "data" / "big.bin").write_bytes(np.random.default_rng(1).bytes(200_000))
    (root / "data" / "empty").mkdir()
    (root / "link").symlink_to("notes.txt")
    return root


def foreign_zarr(root: Path) -> Path:
    xr.Dataset({"x": ("t", np.arange(10.0))}, attrs={"owner": "someone else"}).to_zarr(
        root, mode="w", consolidated=False
    )
    return root


def sweep(path: Path) -> xr.Dataset:
    return xr.open_datatree(path, engine="zarr")["sweep_0"].to_dataset()


def assert_same_volume(a: Path, b: Path) -> None:
    x, y = sweep(a), sweep(b)
    assert sorted(x.data_vars) == sorted(y.data_vars)
    for name in x.data_vars:
        np.testing.assert_array_equal(x[name].values, y[name].values, err_msg=name)
    np.testing.assert_array_equal(x["azimuth"].values, y["azimuth"].values)


# ---- directories this program did not write ---------------------------------------------------


@pytest.fixture(params=["foreign", "cwd", "home", "zarr"])
def not_ours(request, tmp_path, monkeypatch) -> tuple[Path, str]:
    """(the tree to watch, the --out a user gives): a foreign directory, '.' run in a folder
    full of files, a home folder (HOME points at it), a Zarr store another program wrote."""
    if request.param == "foreign":
        root = fill(tmp_path / "project")
        return root, str(root)
    if request.param == "cwd":
        root = fill(tmp_path / "work")
        monkeypatch.chdir(root)
        return root, "."
    if request.param == "home":
        root = fill(tmp_path / "home" / "user")
        (root / ".config").mkdir()
        (root / ".config" / "settings.ini").write_text("[x]\ny = 1\n")
        monkeypatch.setenv("HOME", str(root))
        return root, str(Path.home())
    root = foreign_zarr(tmp_path / "theirs.zarr")
    return root, str(root)


@pytest.mark.parametrize("flags", [[], ["--overwrite"], ["--resume"]], ids=str)
def test_directory_not_ours_is_refused_and_untouched(not_ours, flags, capsys):
    root, out = not_ours
    before = tree_digest(root)
    code, err = pasim(capsys, "run", TINY, "--out", out, *flags)
    assert code == 2, err
    assert "Traceback" not in err
    assert f"error: {out} is " in err and "left untouched" in err
    assert tree_digest(root) == before


@pytest.mark.parametrize("flags", [[], ["--overwrite"], ["--resume"]], ids=str)
def test_a_marker_that_is_not_ours_does_not_make_a_store(flags, tmp_path, capsys):
    """A file named like our marker, written by something else, is not our marker."""
    root = tmp_path / "theirs"
    root.mkdir()
    (root / MARKER).write_text('{"format": "someone-else/2"}')
    before = tree_digest(root)
    code, err = pasim(capsys, "run", TINY, "--out", str(root), *flags)
    assert code == 2 and f"{root} is not a store this program wrote" in err
    assert tree_digest(root) == before


@pytest.mark.parametrize("kept", [0, 12], ids=["empty", "half"])
def test_a_marker_cut_short_is_a_new_store(kept, tmp_path, capsys):
    """A run (or a study's run) stopped by a signal while it marked its new store left the
    marker unfinished: --resume takes the directory as a new store and completes the run,
    as it would an empty one (seen once in ~10 suites: a SIGTERM'd study's resume refused)."""
    root = tmp_path / "cut.zarr"
    root.mkdir()
    open_store(tmp_path / "whole", overwrite=False, resume=False, command="test").release()
    whole = (tmp_path / "whole" / MARKER).read_text()
    (root / MARKER).write_text(whole[:kept])
    assert not is_store(root)
    code, err = pasim(capsys, "run", TINY, "--out", str(root), "--resume")
    assert code == 0, err
    assert is_store(root) and run_state(root)[0]["pasim_complete"] == "true"


def test_resume_and_overwrite_together_are_refused(tmp_path, capsys):
    root = fill(tmp_path / "project")
    before = tree_digest(root)
    code, err = pasim(capsys, "run", TINY, "--out", str(root), "--resume", "--overwrite")
    assert code == 2
    assert "--overwrite" in err and "--resume" in err and "not allowed" in err
    # The store layer refuses the pair too, before looking at the directory.
    with pytest.raises(StoreError, match="exclude each other"):
        open_store(root, overwrite=True, resume=True, command="test")
    assert tree_digest(root) == before


def test_out_that_is_a_file_is_refused_and_untouched(tmp_path, capsys):
    path = tmp_path / "results.csv"
    path.write_text("a,b\n1,2\n")
    for flags in ([], ["--overwrite"], ["--resume"]):
        code, err = pasim(capsys, "run", TINY, "--out", str(path), *flags)
        assert code == 2 and f"{path} is a file, not a store directory" in err
    assert path.read_text() == "a,b\n1,2\n"


def test_store_of_ours_refused_replaced_or_kept(tmp_path, capsys):
    """An existing store: refused without a flag (unchanged), replaced by --overwrite (with
    the new run's numbers, nothing of the old left), kept by --resume when complete."""
    out = tmp_path / "run.zarr"
    assert pasim(capsys, "run", TINY, "--seed", "1", "--out", str(out))[0] == 0
    assert is_store(out) and not (out / LOCK).exists()
    before = tree_digest(out)

    code, err = pasim(capsys, "run", TINY, "--seed", "2", "--out", str(out))
    assert code == 2 and f"{out} exists" in err and "--resume" in err and "--overwrite" in err
    assert tree_digest(out) == before

    code, err = pasim(capsys, "run", TINY, "--seed", "1", "--out", str(out), "--resume")
    assert code == 0 and "already complete" in err
    assert tree_digest(out) == before

    code, err = pasim(capsys, "run", TINY, "--seed", "2", "--out", str(out), "--overwrite")
    assert code == 0, err
    fresh = tmp_path / "fresh.zarr"
    assert pasim(capsys, "run", TINY, "--seed", "2", "--out", str(fresh))[0] == 0
    assert_same_volume(out, fresh)
    assert xr.open_datatree(out, engine="zarr").attrs["seed"] == 2


def test_overwrite_refuses_to_delete_what_a_user_put_in_the_store(tmp_path, capsys):
    """Files a user keeps inside a store (notes, plots, a link to their folder) are named and
    the overwrite refused, everything left as it was; once moved out, it goes ahead."""
    out = tmp_path / "run.zarr"
    assert pasim(capsys, "run", TINY, "--seed", "1", "--out", str(out))[0] == 0
    (out / "NOTES.txt").write_text("inside our store")
    (out / "my_plots").mkdir()
    (out / "my_plots" / "ppi.png").write_bytes(b"png")
    theirs = fill(tmp_path / "theirs")
    (out / "shortcut").symlink_to(theirs, target_is_directory=True)
    (out / "sweep_0" / "stray.txt").write_text("inside a group")
    before, theirs_before = tree_digest(out), tree_digest(theirs)
    code, err = pasim(capsys, "run", TINY, "--seed", "2", "--out", str(out), "--overwrite")
    assert code == 2, err
    assert "Traceback" not in err
    for name in ("NOTES.txt", "my_plots", "shortcut", "sweep_0/stray.txt"):
        assert name in err
    assert tree_digest(out) == before and tree_digest(theirs) == theirs_before
    for name in ("NOTES.txt", "shortcut", "sweep_0/stray.txt"):
        (out / name).unlink()
    (out / "my_plots" / "ppi.png").unlink()
    (out / "my_plots").rmdir()
    assert pasim(capsys, "run", TINY, "--seed", "2", "--out", str(out), "--overwrite")[0] == 0
    assert xr.open_datatree(out, engine="zarr").attrs["seed"] == 2
    assert tree_digest(theirs) == theirs_before


def test_partial_chunk_files_a_killed_run_left_are_the_store_s_own(tmp_path, capsys):
    """A run killed while a chunk file was being written leaves its partial file beside the
    array's metadata, named by this program (``c.1.0.<hex>.partial``) or by zarr (the key's
    last suffix replaced: ``c.<hex>.partial`` for a 1-D array's c.0); --overwrite replaces the
    store, as it would the store without them, where a user's file beside them is refused."""
    from pasim_graph.store import foreign_entries

    out = tmp_path / "run.zarr"
    assert pasim(capsys, "run", TINY, "--seed", "1", "--out", str(out))[0] == 0
    (out / "sweep_0" / "DBZH" / "c.1.0.0123abcd.partial").write_bytes(b"ours")
    (out / "sweep_0" / "range" / "c.4567cdef.partial").write_bytes(b"zarr's")
    assert foreign_entries(out) == []
    (out / "sweep_0" / "range" / "c.notes").write_text("a user's")
    assert foreign_entries(out) == ["sweep_0/range/c.notes"]
    (out / "sweep_0" / "range" / "c.notes").unlink()
    assert pasim(capsys, "run", TINY, "--seed", "2", "--out", str(out), "--overwrite")[0] == 0


GENERIC_SMALL = ["run", str(GRAPHS / "generic_radar.yaml"), "--sector", "282:284"]
GENERIC_SMALL += ["--set", "scan.pulses=8", "--seed", "3"]


@pytest.fixture(scope="module")
def finished_generic(tmp_path_factory):
    """A finished store of the generic radar on the bundled volume (copied per test)."""
    out = tmp_path_factory.mktemp("generic") / "run.zarr"
    res = run_cli(*GENERIC_SMALL, "--out", str(out))
    assert res.returncode == 0, res.stderr
    return out


@pytest.mark.parametrize("fault", ["truncated truth", "wrong-format truth", "disk refused"])
def test_failed_overwrite_leaves_the_old_store_byte_for_byte(
    fault, finished_generic, tmp_path, capsys, monkeypatch
):
    """--overwrite empties the old store only once the new run has read its inputs and passed
    its checks: a run that fails before then leaves it exactly as it was."""
    import shutil

    out = tmp_path / "run.zarr"
    shutil.copytree(finished_generic, out, symlinks=True)
    before = tree_digest(out)
    args = [*GENERIC_SMALL[1:], "--out", str(out), "--overwrite"]
    if fault == "truncated truth":
        bad = tmp_path / "KLBB_truncated"
        bad.write_bytes(
            (ROOT / "blocks" / "data" / "KLBB20160601_150025_V06").read_bytes()[:300_000]
        )
        args += ["--truth", str(bad)]
    elif fault == "wrong-format truth":
        bad = tmp_path / "scene.h5"
        bad.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(4096))
        args += ["--truth", str(bad)]
    else:
        import pasim_graph.resources as checks

        real = shutil.disk_usage

        def tiny(path):
            usage = real(path)
            return type(usage)(usage.total, usage.used, 1000)

        monkeypatch.setattr(checks.shutil, "disk_usage", tiny)
    code, err = pasim(capsys, *args)
    assert code == 2, err
    assert "Traceback" not in err
    assert tree_digest(out) == before, err
    assert_same_volume(out, finished_generic)


def test_empty_directory_becomes_a_store(tmp_path, capsys):
    out = tmp_path / "empty"
    out.mkdir()
    code, err = pasim(capsys, "run", TINY, "--out", str(out))
    assert code == 0, err
    assert is_store(out) and run_state(out)[0]["pasim_complete"] == "true"


# ---- one writer per store ---------------------------------------------------------------------

_HOLDER = """
import sys
from pasim_graph.store import open_store
lock = open_store(sys.argv[1], overwrite=False, resume=False, command="pasim run held-by-test")
print("held", flush=True)
sys.stdin.read()
lock.release()
"""


def test_second_run_while_the_first_holds_the_store_is_refused_naming_it(tmp_path, capsys):
    out = tmp_path / "busy.zarr"
    holder = subprocess.Popen(
        [sys.executable, "-c", _HOLDER, str(out)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    try:
        assert holder.stdout.readline().strip() == "held"
        before = tree_digest(out)
        for flags in ([], ["--overwrite"], ["--resume"]):
            code, err = pasim(capsys, "run", TINY, "--out", str(out), *flags)
            assert code == 2, err
            assert f"{out} is being written by another run" in err
            assert f"pid {holder.pid} on {socket.gethostname()}" in err
            assert "pasim run held-by-test" in err
            assert tree_digest(out) == before
    finally:
        holder.communicate("")
    assert holder.returncode == 0
    # Once the first run is gone the store is free.
    code, err = pasim(capsys, "run", TINY, "--out", str(out), "--resume")
    assert code == 0, err


def _race(paths: list[str], barrier, results) -> None:
    """One racer: for each path, start with the others, try to take the store, and hold it
    until every racer has tried."""
    for path in paths:
        barrier.wait()
        lock = None
        try:
            lock = open_store(path, overwrite=False, resume=False, command=f"racer {os.getpid()}")
            results.put(("won", os.getpid(), path, ""))
        except StoreError as exc:
            results.put(("refused", os.getpid(), path, str(exc)))
        barrier.wait()
        if lock is not None:
            lock.release()


def test_racing_runs_one_wins_the_others_name_it(tmp_path):
    """Three processes released together on one new store, 10 stores in a row: exactly one
    takes each, every other is refused naming it, and no lock is left behind."""
    ctx = multiprocessing.get_context("spawn")
    paths = [str(tmp_path / f"store{i}") for i in range(10)]
    barrier, results = ctx.Barrier(3), ctx.Queue()
    procs = [ctx.Process(target=_race, args=(paths, barrier, results)) for _ in range(3)]
    for p in procs:
        p.start()
    outcome = [results.get(timeout=120) for _ in range(3 * len(paths))]
    for p in procs:
        p.join(30)
        assert p.exitcode == 0
    for path in paths:
        tries = [o for o in outcome if o[2] == path]
        winners = [pid for what, pid, _, _ in tries if what == "won"]
        assert len(tries) == 3 and len(winners) == 1, tries
        for what, _, _, message in tries:
            if what == "refused":
                assert "is being written by another run" in message, message
                assert f"pid {winners[0]} " in message and f"racer {winners[0]}" in message
        assert is_store(path) and not (Path(path) / LOCK).exists()


# A run caught between taking the lock and saying who it is: it holds the flock, the lock file
# is still empty, and its marker is half written.
_SLOW_TAKER = """
import fcntl, json, os, sys, time
store = sys.argv[1]
os.makedirs(store)
fd = os.open(os.path.join(store, "pasim-run.lock"), os.O_RDWR | os.O_CREAT, 0o644)
fcntl.flock(fd, fcntl.LOCK_EX)
with open(os.path.join(store, "pasim-store.json"), "w") as f:
    f.write('{"format": "pasim-st')
print("locked", flush=True)
time.sleep(0.3)
me = {"pid": os.getpid(), "host": "here", "command": "pasim run slow"}
os.pwrite(fd, json.dumps(me).encode(), 0)
sys.stdin.read()
"""


def test_run_that_just_took_the_lock_is_named_not_mistaken(tmp_path):
    """Losing a race by a hair: the store holds only a locked, still empty lock file and a
    half-written marker. The loser is refused naming the winner once it has said who it is,
    not "owner unknown", and not told the store is a directory this program did not write."""
    out = tmp_path / "new.zarr"
    taker = subprocess.Popen(
        [sys.executable, "-c", _SLOW_TAKER, str(out)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert taker.stdout.readline().strip() == "locked"
        with pytest.raises(StoreError) as info:
            open_store(out, overwrite=False, resume=False, command="test")
    finally:
        taker.communicate("")
    assert str(info.value) == (
        f"{out} is being written by another run (pid {taker.pid} on here, started None: "
        "pasim run slow); wait for it to finish or choose another --out"
    )


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The race graph run alone, start to end (in this process)."""
    out = tmp_path_factory.mktemp("ref") / "solo.zarr"
    assert main([*RACE, "--out", str(out)]) == 0
    return out


def test_two_runs_started_together_one_refused_one_intact(tmp_path, reference):
    out = tmp_path / "shared.zarr"
    argv = [sys.executable, "-m", "pasim_graph", *RACE, "--out", str(out)]
    procs = [
        subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    errors = [p.communicate(timeout=300)[1] for p in procs]
    results = [(p.pid, p.returncode, err) for p, err in zip(procs, errors, strict=True)]
    codes = sorted(code for _, code, _ in results)
    assert codes == [0, 2], results
    (winner, _, _), (_, _, err) = sorted(results, key=lambda r: r[1])
    assert "Traceback" not in err
    assert f"{out} is being written by another run (pid {winner} on {socket.gethostname()}" in err
    assert "pasim run" in err and str(out) in err
    assert run_state(out)[0]["pasim_complete"] == "true" and not (out / LOCK).exists()
    assert_same_volume(out, reference)
    scores = [summarize(open_volume(p)["sweep_0"].to_dataset()) for p in (out, reference)]
    assert scores[0] == scores[1] and scores[0]["DBZH"]["count"] > 0
    # Chunks written from several threads at once print nothing but the run's own lines.
    assert "warning" not in dict((code, e) for _, code, e in results)[0]


def test_stale_lock_of_a_killed_run_is_taken_over_by_resume(tmp_path, reference, capsys):
    out = tmp_path / "killed.zarr"
    proc = kill_run_part_way(RACE, out, limit_s=120, poll_s=0.02)
    # The lock file outlives its run; the kernel dropped the run's flock.
    assert json.loads((out / LOCK).read_text())["pid"] == proc.pid
    before = tree_digest(out)

    code, err = pasim(capsys, *RACE, "--out", str(out))
    assert code == 2
    assert f"{out} exists (a run that stopped early left it)" in err and "--resume" in err
    assert tree_digest(out) == before  # the crashed run's lock file too

    code, err = pasim(capsys, *RACE, "--out", str(out), "--resume")
    assert code == 0, err
    assert f"taking over the lock of a run that stopped early (pid {proc.pid} on" in err
    assert not (out / LOCK).exists() and (out / MARKER).exists()
    assert_same_volume(out, reference)


def test_resume_of_another_runs_store_leaves_it_as_it_was(tmp_path, capsys):
    out = tmp_path / "run.zarr"
    assert pasim(capsys, "run", TINY, "--seed", "1", "--out", str(out))[0] == 0
    before = tree_digest(out)
    code, err = pasim(capsys, "run", TINY, "--seed", "2", "--out", str(out), "--resume")
    assert code == 2 and "written by another run" in err and "--overwrite" in err
    assert tree_digest(out) == before
