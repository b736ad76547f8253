from __future__ import annotations

import contextlib
import io
import json
import os
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any, NamedTuple

import pytest


def _pin_numerics() -> None:
    """NumPy picks its SIMD kernels by the CPU it finds (AVX2 on one machine, AVX-512 on the
    next) and OpenBLAS its own likewise; their exp, sin and products differ in the last bit,
    and so does every number a graph gives (float32 moments by up to 4e-6 dB of DBZH, 5e-5 deg
    of PHIDP: docs/scaling.md). The graphs' fingerprints (tests/fingerprints.json) are
    recorded under the AVX2/FMA3 kernels (NumPy's X86_V3, OpenBLAS's Haswell) that every
    x86-64 machine since 2015 has: each process of the suite (test workers, and the `pasim`
    and Dask processes they start, which inherit the environment) runs those, whatever the
    machine has beyond them. Set before NumPy is imported (pyproject's ``-p no:zarr`` keeps
    zarr's pytest plugin from importing it first); a variable already set is left alone."""
    if platform.machine() not in ("x86_64", "AMD64"):
        return
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
        flags = next(line for line in lines if line.startswith("flags")).split()
    except (OSError, StopIteration):
        return
    if {"avx2", "fma"} <= set(flags):  # Haswell kernels on a CPU without them would crash
        os.environ.setdefault("NPY_DISABLE_CPU_FEATURES", "X86_V4 AVX512_ICL AVX512_SPR")
        os.environ.setdefault("OPENBLAS_CORETYPE", "Haswell")


_pin_numerics()

ROOT = Path(__file__).resolve().parents[1]
GRAPHS = ROOT / "graphs"
FIXTURES = Path(__file__).parent / "fixtures"


def run_cli(
    *args: str, env: dict[str, str] | None = None, cwd: Path | None = None
) -> subprocess.CompletedProcess[str]:
    """Run ``pasim`` in a fresh interpreter, as a user would."""
    full_env = {**os.environ, **(env or {})}
    return subprocess.run(
        [sys.executable, "-m", "pasim_graph", *args],
        capture_output=True,
        text=True,
        env=full_env,
        cwd=cwd or ROOT,
        timeout=600,
    )


def pytest_xdist_auto_num_workers(config) -> int:
    """``-n auto``: one test worker more than the cores this process may use. A worker spends
    about a sixth of its time waiting (a browser drawing, a studio answering, a process
    starting: 260 s of 1,521 on the 2-core machine), which the extra worker fills: the suite
    took 13.7 minutes with 2 workers and 12.0 with 3 (2026-11-28, same commit, quiet)."""
    if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
        return int(os.environ["PYTEST_XDIST_AUTO_NUM_WORKERS"])
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return (cores or 1) + 1


@pytest.fixture(autouse=True)
def dask_scheduler_left_as_found():
    """Every test leaves dask's global scheduler as it found it: a distributed client left
    as the default (or closed out of order) sets it for every later test of the process,
    whose computations then fail far from the cause; this names the test that left it."""
    import dask

    before = dask.config.get("scheduler", None)
    yield
    after = dask.config.get("scheduler", None)
    assert after == before, f"the test left dask's scheduler set to {after!r} (was {before!r})"


@pytest.fixture(scope="session")
def truth_dataset():
    """The bundled scene as the truth block hands it on."""
    import numpy as np
    from pasim_blocks.truth.nexrad import NexradTruth

    from pasim_graph import Chunk

    block = NexradTruth(name="truth")
    return block.process({}, Chunk(beams=np.arange(0), resource=block.load()))["truth"]


def exit_code(*argv: str) -> Any:
    """``pasim ARGV`` in this process: its exit code (argparse's SystemExit too)."""
    from pasim_graph.cli import main

    try:
        return main(list(argv))
    except SystemExit as exc:
        return exc.code


def pasim(capsys, *argv: str) -> tuple[int, str]:
    """``pasim ARGV`` in this process: exit code and stderr."""
    code = exit_code(*argv)
    return code, capsys.readouterr().err


def pasim_out(capsys, *argv: str) -> tuple[int, str, str]:
    """``pasim ARGV`` in this process: exit code, stdout and stderr."""
    code = exit_code(*argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def kill_run_part_way(
    args: list[str], out: Path, limit_s: float = 300.0, poll_s: float = 0.05
) -> subprocess.Popen:
    """Start ``pasim ARGS --out OUT`` in a fresh process and SIGKILL it once at least one
    chunk of the store is flagged done and more than two are not (the test fails if the run
    ends first); returns the killed process."""
    import signal
    import time

    from pasim_graph.store import run_state

    proc = subprocess.Popen(
        [sys.executable, "-m", "pasim_graph", *args, "--out", str(out)],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        state = run_state(out) if out.exists() else None
        if state is not None and 1 <= state[1].sum() < state[1].size - 2:
            break
        if proc.poll() is not None:
            pytest.fail("the run finished before it could be killed")
        time.sleep(poll_s)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    return proc


def free_port() -> int:
    """A TCP port free on the loopback interface now."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def store_values(path: Path) -> dict[str, Any]:
    """Every array of a store by its path in the store (the per-chunk flags aside)."""
    import numpy as np
    import zarr

    out: dict[str, Any] = {}

    def walk(group, prefix: str) -> None:
        for name, array in group.arrays():
            if name != "pasim_chunk_done":
                out[prefix + name] = np.asarray(array[...])
        for name, sub in group.groups():
            walk(sub, f"{prefix}{name}/")

    walk(zarr.open_group(str(path), mode="r"), "")
    return out


class Result(NamedTuple):
    """What :func:`pasim_result` gives: run_cli's fields."""

    returncode: int
    stdout: str
    stderr: str


def pasim_result(capsys, *argv: str) -> Result:
    """``pasim ARGV`` in this process, with :func:`run_cli`'s fields: for checks of a
    command's exit code and words (an uncaught exception fails the test as a traceback would
    fail it). :func:`run_cli` stays where the process itself is the subject: signals, the
    environment, plugins installed for it, the interpreter's exit."""
    return Result(*pasim_out(capsys, *argv))


def pasim_in_process(*argv: str) -> Result:
    """``pasim ARGV`` in this process with its words kept, where no ``capsys`` is at hand (a
    module's fixture that makes a store the module's tests read): :func:`run_cli`'s fields
    without an interpreter's start (3-5 s of imports)."""
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = exit_code(*argv)
    return Result(code, out.getvalue(), err.getvalue())


def generic_expected_run(out: Path, sector: str) -> Path:
    """``out``: the generic radar over ``sector`` at the fastest fidelity level (expected),
    run in this process: a store for tests of what reads stores."""
    args = ["run", str(GRAPHS / "generic_radar.yaml"), "--sector", sector]
    res = pasim_in_process(*args, "--set", "weather.method=expected", "--out", str(out))
    assert res.returncode == 0, res.stderr
    return out


def same_sweep(a, b) -> None:
    """Two stores' sweeps hold the same variables with the same values (NaN where NaN)."""
    import numpy as np
    import xarray as xr

    x = xr.open_datatree(a, engine="zarr")["sweep_0"].to_dataset()
    y = xr.open_datatree(b, engine="zarr")["sweep_0"].to_dataset()
    assert sorted(x.data_vars) == sorted(y.data_vars)
    for name in y.data_vars:
        np.testing.assert_array_equal(x[name].values, y[name].values, err_msg=name)


@pytest.fixture
def folder(request, tmp_path):
    """A copy of graphs/ for a studio to serve, with the broken fixtures beside them where
    the test module sets ``SERVE_BROKEN``."""
    import shutil

    root = tmp_path / "graphs"
    shutil.copytree(GRAPHS, root)
    if getattr(request.module, "SERVE_BROKEN", False):
        shutil.copytree(FIXTURES / "broken", root / "broken")
    return root


@pytest.fixture
def studio(request, folder, tmp_path):
    """A studio serving ``folder`` on a free port, with the test module's ``TOKEN``."""
    from pasim_graph.studio.server import StudioServer

    server = StudioServer(folder, 0, token=request.module.TOKEN, runs_dir=tmp_path / "runs")
    server.serve_in_thread()
    yield server
    server.close()


def assert_chunk_grids_are_each_beams_fields(block, az, el, seed: int) -> None:
    """An array block's chunk of pattern grids (``beam_grids``, written in place) holds, bit
    for bit and in the same dtype, each beam's own fields stacked per polarisation as the
    blocks stacked them before: (H, V) co-polar and (H, V) cross-polar on the offset grid."""
    import numpy as np

    co, cross = block.beam_grids(az, el, seed, None)
    shape = (block.d_el.size, block.d_az.size)
    for b in range(az.size):
        h_co, v_co, h_cross, v_cross = block.beam_fields(float(az[b]), float(el[b]), seed, None)
        one_co = np.stack([np.broadcast_to(h_co, shape), np.broadcast_to(v_co, shape)])
        one_cross = np.stack([np.broadcast_to(h_cross, shape), np.broadcast_to(v_cross, shape)])
        assert co[b].dtype == one_co.dtype and cross[b].dtype == one_cross.dtype
        np.testing.assert_array_equal(co[b], one_co)
        np.testing.assert_array_equal(cross[b], one_cross)


TINY_UNIFORM = str(FIXTURES / "tiny_uniform.yaml")
#: The tiny uniform run the store-damage and missing-array tests take apart (one beam a chunk).
TINY_RUN = ["run", TINY_UNIFORM, "--chunk", "1", "--seed", "5", "--save-iq"]


@pytest.fixture(scope="module")
def original(tmp_path_factory):
    """A finished store of :data:`TINY_RUN` (copied by the tests that damage it)."""
    from pasim_graph.cli import main

    out = tmp_path_factory.mktemp("orig") / "run.zarr"
    assert main([*TINY_RUN, "--out", str(out)]) == 0
    return out


TINY_STUDY = FIXTURES / "study" / "tiny_study.yaml"


def tiny_study_file(
    folder: Path,
    seeds: str,
    edit: tuple[str, str] = ("", ""),
    graphs: Path = FIXTURES / "study",
) -> Path:
    """The tiny study's file written in ``folder`` with ``seeds`` (``"[0, 1, 2]"``), its graphs
    found in ``graphs``, and ``edit`` (old, new) made to its text."""
    text = TINY_STUDY.read_text().replace("graph: ", f"graph: {graphs}/")
    text = text.replace("seeds: [0]", f"seeds: {seeds}")
    if edit[0]:
        assert edit[0] in text
        text = text.replace(*edit)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "study.yaml").write_text(text)
    return folder / "study.yaml"


@pytest.fixture(scope="session")
def tiny_study(tmp_path_factory) -> Path:
    """The tiny study's finished output folder, built once for the whole test run: the first
    test worker (pytest-xdist) to need it runs ``pasim study --no-report`` then ``pasim study
    DIR --report-only`` under a file lock, the others wait for it and share it. Tests read it;
    a test that changes a study copies it first. (A study that draws its report at its end:
    tests/study/test_study_volume.py.)"""
    import fcntl

    from pasim_graph.cli import main

    base = tmp_path_factory.getbasetemp()
    # Under pytest-xdist each worker's base folder sits in one folder common to the run.
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    out = shared / "tiny-study" / "out"
    with open(shared / "tiny-study.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        built = shared / "tiny-study" / "built"
        if not built.exists():
            built.parent.mkdir(exist_ok=True)
            if out.exists():  # a worker stopped half way: start again
                import shutil

                shutil.rmtree(out)
            # Scores first, then the report from the folder alone (--report-only), the
            # stores' times taken between the two: the report-only test reads them.
            assert main(["study", str(TINY_STUDY), "--out", str(out), "--no-report"]) == 0
            times = {str(p): p.stat().st_mtime_ns for p in out.rglob("*.zarr/**/*")}
            (out.parent / "stores-before-report.json").write_text(json.dumps(times))
            with contextlib.redirect_stderr(io.StringIO()) as err:
                assert main(["study", str(out), "--report-only"]) == 0
            (out.parent / "report-only.err").write_text(err.getvalue())
            built.touch()
    return out
