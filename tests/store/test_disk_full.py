"""A disk that fills at any moment of a run ends it cleanly and loses nothing written.

The fault is injected where a file of the store is written: zarr's file write
(``zarr.storage._local._put``: the layout, metadata, consolidation) and the chunk files'
(``pasim_graph.store.writes.put_file``): after N files an ``OSError(ENOSPC)``, as a full file
system raises it. For N from the store's creation through its chunks to the final
consolidation, the run exits 2 naming the store, the free space and the way on, with no
traceback; the store is then either absent (nothing was kept) or incomplete and resumable;
``--resume`` with the space back gives a store identical to an uninterrupted run's.
"""

from __future__ import annotations

import errno
import threading
from typing import ClassVar

import pytest
import zarr.storage._local as zlocal

import pasim_graph.store.writes as writes
from pasim_graph.cli import main
from pasim_graph.store import is_store, run_state

from ..conftest import GRAPHS, pasim, same_sweep

RUN = ["run", str(GRAPHS / "uniform_ideal.yaml"), "--set", "scan.azimuth_stop_deg=8"]
RUN += ["--set", "scan.pulses=16", "--chunk", "2", "--seed", "4"]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "ref.zarr"
    assert main([*RUN, "--out", str(out)]) == 0
    return out


def count_writes(monkeypatch, tmp_path, capsys) -> int:
    disk = FullAfter(None)
    disk.install(monkeypatch)
    assert pasim(capsys, *RUN, "--out", str(tmp_path / "count.zarr"))[0] == 0
    disk.remove(monkeypatch)
    return disk.calls


class FullAfter:
    """Every file write of a store (zarr's and the chunk files'), failing with ENOSPC from
    the n-th on (threads share the count); None: never."""

    REAL: ClassVar = {zlocal: zlocal._put, writes: writes.put_file}
    NAME: ClassVar = {zlocal: "_put", writes: "put_file"}

    def __init__(self, n: int | None):
        self.n, self.calls, self.lock = n, 0, threading.Lock()

    def wrap(self, real):
        def write(*args, **kwargs):
            with self.lock:
                self.calls += 1
                hit = self.n is not None and self.calls >= self.n
            if hit:
                raise OSError(errno.ENOSPC, "No space left on device")
            return real(*args, **kwargs)

        return write

    def install(self, monkeypatch) -> None:
        for module, real in self.REAL.items():
            monkeypatch.setattr(module, self.NAME[module], self.wrap(real))

    def remove(self, monkeypatch) -> None:
        for module, real in self.REAL.items():
            monkeypatch.setattr(module, self.NAME[module], real)


# Eight writes in the default suite (the template's, a spread through the chunks, the last
# ones); every tenth of the run beside them with -m slow.
@pytest.mark.parametrize("spread", ["sample", pytest.param("every", marks=pytest.mark.slow)])
def test_disk_full_at_every_stage_exits_2_and_resume_completes(
    reference, tmp_path, capsys, monkeypatch, spread
):
    total = count_writes(monkeypatch, tmp_path, capsys)
    assert total > 50
    # the first writes (the template), a spread through the chunks, and the very last ones
    points = {1, 5, total // 4, total // 2, 3 * total // 4, total - 2, total - 1, total}
    if spread == "every":
        points |= {2} | {total * k // 10 for k in range(5, 10)}
    points = sorted(points)
    outcomes = {"none kept": 0, "resumable": 0}
    for n in points:
        out = tmp_path / f"full{n}.zarr"

        disk = FullAfter(n)
        disk.install(monkeypatch)
        code, err = pasim(capsys, *RUN, "--out", str(out))
        disk.remove(monkeypatch)
        assert code == 2, f"write {n}: {err}"
        assert "Traceback" not in err, err
        assert f"{out}: the disk is full" in err and "free" in err, err
        if out.exists() and is_store(out) and run_state(out) is not None:
            outcomes["resumable"] += 1
            assert "--resume" in err, err
            assert run_state(out)[0].get("pasim_complete") != "true", f"write {n}"
            code, err = pasim(capsys, *RUN, "--out", str(out), "--resume")
            assert code == 0, f"resume after write {n}: {err}"
            same_sweep(out, reference)
        else:
            outcomes["none kept"] += 1
            assert "run it again" in err, err
            assert pasim(capsys, *RUN, "--out", str(out))[0] == 0, f"rerun after write {n}"
            same_sweep(out, reference)
    # (the layout is the first quarter of the writes or more: full there, nothing is kept)
    assert outcomes["resumable"] >= (5 if spread == "every" else 4), outcomes


@pytest.fixture
def tmpfs_3mb(tmp_path):
    """A real 3 MB file system (tmpfs), where this machine lets the tests mount one."""
    import subprocess

    mnt = tmp_path / "tmpfs"
    mnt.mkdir()
    res = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", str(mnt)], capture_output=True
    )
    if res.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {res.stderr.decode().strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", str(mnt)], check=False)


def test_a_run_that_cannot_fit_a_3_mb_disk_is_refused_before_work(tmpfs_3mb, capsys):
    """The generic radar's 90 beams write 3.9 MB: refused with the estimate, nothing left."""
    out = tmpfs_3mb / "run.zarr"
    code, err = pasim(capsys, "run", str(GRAPHS / "generic_radar.yaml"), "--out", str(out))
    assert code == 2, err
    assert "this run would write about" in err and "MiB is free there" in err, err
    assert "Traceback" not in err
    assert not out.exists()
