"""A disk that fills at any moment of a run ends it cleanly and loses nothing written.

The fault is injected where zarr writes a file (``zarr.storage._local._put``, the one place
its local store writes bytes): after N files an ``OSError(ENOSPC)``, as a full file system
raises it. For N from the store's creation through its chunks to the final consolidation,
the run exits 2 naming the store, the free space and the way on, with no traceback; the
store is then either absent (nothing was kept) or incomplete and resumable; ``--resume``
with the space back gives a store identical to an uninterrupted run's.
"""

from __future__ import annotations

import errno
import threading

import pytest
import zarr.storage._local as zlocal

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
    calls = [0]
    real = zlocal._put

    def counting(*args, **kwargs):
        calls[0] += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(zlocal, "_put", counting)
    assert pasim(capsys, *RUN, "--out", str(tmp_path / "count.zarr"))[0] == 0
    monkeypatch.setattr(zlocal, "_put", real)
    return calls[0]


class FullAfter:
    """zarr's file write, failing with ENOSPC from the n-th call on (threads share it)."""

    def __init__(self, n: int, real):
        self.n, self.real, self.calls, self.lock = n, real, 0, threading.Lock()

    def __call__(self, *args, **kwargs):
        with self.lock:
            self.calls += 1
            hit = self.calls >= self.n
        if hit:
            raise OSError(errno.ENOSPC, "No space left on device")
        return self.real(*args, **kwargs)


# Eight writes in the default suite (the template's, a spread through the chunks, the last
# ones); every tenth of the run beside them with -m slow.
@pytest.mark.parametrize("spread", ["sample", pytest.param("every", marks=pytest.mark.slow)])
def test_disk_full_at_every_stage_exits_2_and_resume_completes(
    reference, tmp_path, capsys, monkeypatch, spread
):
    total = count_writes(monkeypatch, tmp_path, capsys)
    assert total > 50
    real = zlocal._put
    # the first writes (the template), a spread through the chunks, and the very last ones
    points = {1, 5, total // 4, total // 2, 3 * total // 4, total - 2, total - 1, total}
    if spread == "every":
        points |= {2} | {total * k // 10 for k in range(5, 10)}
    points = sorted(points)
    outcomes = {"none kept": 0, "resumable": 0}
    for n in points:
        out = tmp_path / f"full{n}.zarr"

        monkeypatch.setattr(zlocal, "_put", FullAfter(n, real))
        code, err = pasim(capsys, *RUN, "--out", str(out))
        monkeypatch.setattr(zlocal, "_put", real)
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
