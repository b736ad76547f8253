"""Every bad input of issue 14's list: exit 2, a message naming the culprit and what was
expected, no traceback, no silent wrong result, and no store left behind.

Most cases run ``pasim`` in this process (``pasim_graph.cli.main``: an uncaught exception
fails the test); those that need another user, a read-only mount or a memory limit run it in
a subprocess.
"""

from __future__ import annotations

import argparse
import os
import pwd
import resource
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import xarray as xr

from pasim_graph import cli
from pasim_graph.cli import main

from ..conftest import FIXTURES, GRAPHS, ROOT

TINY = str(FIXTURES / "tiny_uniform.yaml")
REFUSED = FIXTURES / "refused"
UNIFORM = str(GRAPHS / "uniform_ideal.yaml")
GENERIC = str(GRAPHS / "generic_radar.yaml")
LEVEL2 = ROOT / "blocks" / "data" / "KLBB20160601_150025_V06"


def pasim(capsys, *argv: str) -> tuple[int, str]:
    """``pasim ARGV`` in this process: exit code (argparse's SystemExit too) and stderr."""
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err


def refused(capsys, *argv: str) -> str:
    code, err = pasim(capsys, *argv)
    assert code == 2, err
    return err


# ---- the graph file ---------------------------------------------------------------------------

# fixture -> what the message must say: the file and line, the key, and where it was first
DUPLICATES = {
    "duplicate_variable.yaml": ["duplicate_variable.yaml:4:", "'variables.frequency_hz'", "3"],
    "duplicate_param.yaml": [
        "duplicate_param.yaml:8:",
        "block 'receiver'",
        "'blocks.receiver.params.snr_db'",
        "line 8",
    ],
    "duplicate_section.yaml": ["duplicate_section.yaml:36:", "'connections'", "line 14"],
    "duplicate_block_field.yaml": [
        "duplicate_block_field.yaml:6:",
        "block 'mf'",
        "'blocks.mf.type'",
        "line 6",
    ],
    "duplicate_block.yaml": ["duplicate_block.yaml:7:", "block 'mf'", "'blocks.mf'", "line 6"],
}


@pytest.mark.parametrize("name", sorted(DUPLICATES))
def test_duplicate_key_is_named_with_both_lines(name, capsys, tmp_path):
    """A key written twice is never silently resolved to the last value."""
    err = refused(capsys, "validate", str(REFUSED / name))
    assert "duplicate key" in err and "each key may appear once" in err
    for word in DUPLICATES[name]:
        assert word in err, (word, err)
    out = tmp_path / "x.zarr"
    assert "duplicate key" in refused(capsys, "run", str(REFUSED / name), "--out", str(out))
    assert not out.exists()


def test_graph_file_not_utf8_names_the_byte_and_line(capsys):
    err = refused(capsys, "validate", str(REFUSED / "not_utf8.yaml"))
    assert "not_utf8.yaml:6:" in err and "not UTF-8" in err and "byte 0xe9" in err
    assert "save the graph file as UTF-8" in err


def test_graph_without_blocks_is_refused_at_run(capsys, tmp_path):
    out = tmp_path / "x.zarr"
    err = refused(capsys, "run", str(REFUSED / "no_blocks.yaml"), "--out", str(out))
    assert "no_blocks.yaml" in err and "the graph has no blocks" in err
    assert not out.exists()


# Found by the property test (tests/engine/test_cli_property.py): each raised a traceback.


def test_yaml_tag_the_safe_loader_refuses_is_named(capsys):
    err = refused(capsys, "validate", str(REFUSED / "python_tag.yaml"))
    assert "python_tag.yaml:12: malformed YAML" in err and "python/object:os.system" in err


def test_file_cut_after_a_key(capsys):
    err = refused(capsys, "validate", str(REFUSED / "cut_after_a_key.yaml"))
    assert "cut_after_a_key.yaml:1: missing 'blocks'" in err


@pytest.mark.parametrize("value", ["@", "*a", "%", "\x1f", "!!python/name:os.system", "[1,"])
def test_set_value_that_is_not_yaml_is_refused_by_the_parameter(value, capsys):
    err = refused(capsys, "validate", TINY, "--set", f"scan.prt_s={value}")
    assert f"block 'scan', parameter 'prt_s': expected float, found str {value!r}" in err


def test_chunk_larger_than_the_scan(capsys, tmp_path):
    """--chunk 2**64 on two beams: one chunk of two beams (zarr and dask took the 2**64)."""
    out = tmp_path / "x.zarr"
    code, err = pasim(capsys, "run", TINY, "--chunk", str(2**64), "--out", str(out))
    assert code == 0, err
    assert "2 beams in chunks of 2," in err
    assert xr.open_datatree(out, engine="zarr").attrs["chunk_beams"] == 2


# ---- where the store goes ---------------------------------------------------------------------


def _as_nobody(cwd: Path) -> tuple[list[str], object]:
    """How to run this Python as user nobody: a command prefix and a preexec_fn.

    setpriv(1) first (it finds the interpreter before it drops root's rights, which matters
    when the interpreter sits under /root), else setuid in the child; skips the test when
    neither gives a nobody that can import pasim_graph.
    """
    try:
        user = pwd.getpwnam("nobody")
    except KeyError:
        pytest.skip("no user 'nobody' to run as (root ignores permissions)")
    uid, gid = user.pw_uid, user.pw_gid

    def drop() -> None:
        os.setgroups([])
        os.setgid(gid)
        os.setuid(uid)

    ways: list[tuple[list[str], object]] = []
    if shutil.which("setpriv"):
        ways.append(([f"--reuid={uid}", f"--regid={gid}", "--clear-groups"], None))
    ways.append(([], drop))
    why = ""
    for flags, preexec in ways:
        prefix = ["setpriv", *flags] if flags else []
        try:
            probe = subprocess.run(
                [*prefix, sys.executable, "-c", "import os, pasim_graph; print(os.getuid())"],
                capture_output=True,
                text=True,
                cwd=cwd,
                preexec_fn=preexec,
                timeout=120,
            )
        except OSError as exc:
            why = str(exc)
            continue
        if probe.returncode == 0 and probe.stdout.strip() == str(uid):
            return prefix, preexec
        why = probe.stderr.strip().splitlines()[-1:] or "no output"
    pytest.skip(f"cannot run this Python as user nobody here ({why})")


@pytest.fixture
def public_tmp():
    """A temporary directory every user can enter (pytest's tmp_path is private to root)."""
    path = Path(tempfile.mkdtemp(prefix="pasim-public-"))
    path.chmod(0o755)
    yield path
    shutil.rmtree(path)


def test_out_where_the_user_may_not_write_is_refused(public_tmp):
    """Root ignores permissions, so as root the run is made as user nobody, under a directory
    owned by root (mode 755): both a new store in it and the directory itself."""
    target = public_tmp / "locked"
    if os.geteuid() != 0:
        target.mkdir(mode=0o555)
        prefix, preexec = [], None
    else:
        target.mkdir(mode=0o755)
        prefix, preexec = _as_nobody(public_tmp)
    for out, words in (
        (target / "new.zarr", [f"cannot create {target / 'new.zarr'}", "ermission denied"]),
        (target, [f"cannot write to {target}", "permission denied"]),
    ):
        res = subprocess.run(
            [*prefix, sys.executable, "-m", "pasim_graph", "run", TINY, "--out", str(out)],
            capture_output=True,
            text=True,
            cwd=public_tmp,
            env={**os.environ, "HOME": str(public_tmp)},
            preexec_fn=preexec,
            timeout=300,
        )
        assert res.returncode == 2, res.stderr
        assert "Traceback" not in res.stderr
        for word in words:
            assert word in res.stderr, (word, res.stderr)
    assert list(target.iterdir()) == []


def test_out_on_a_read_only_file_system_is_refused(tmp_path):
    """A read-only bind mount (in a private mount namespace); skipped where mounts are not
    allowed."""
    ro = tmp_path / "ro"
    ro.mkdir()
    if shutil.which("unshare") is None:
        pytest.skip("unshare(1) not available to make a read-only mount")
    mount = f"mount --bind {ro} {ro} && mount -o remount,bind,ro {ro}"
    probe = subprocess.run(["unshare", "-m", "sh", "-c", mount], capture_output=True)
    if probe.returncode != 0:
        pytest.skip(f"cannot make a read-only mount here: {probe.stderr.decode().strip()}")
    for out, words in (
        (ro / "new.zarr", [f"cannot create {ro / 'new.zarr'}", "Read-only file system"]),
        (ro, [f"cannot write to {ro}", "the file system is read-only"]),
    ):
        cmd = f"{mount} && exec {sys.executable} -m pasim_graph run {TINY} --out {out}"
        res = subprocess.run(
            ["unshare", "-m", "sh", "-c", cmd], capture_output=True, text=True, cwd=ROOT
        )
        assert res.returncode == 2, res.stderr
        assert "Traceback" not in res.stderr
        for word in words:
            assert word in res.stderr, (word, res.stderr)


def test_out_in_sys_is_refused(capsys):
    """/sys takes no new directories, even from root."""
    err = refused(capsys, "run", TINY, "--out", "/sys/pasim-test.zarr")
    assert "cannot create /sys/pasim-test.zarr" in err


# ---- options ------------------------------------------------------------------------------------


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_is_refused_quickly(capsys, tmp_path):
    """Nothing listens at the address: refused in seconds (dask alone retries for 30 s),
    before any work starts."""
    address = f"tcp://127.0.0.1:{_closed_port()}"
    out = tmp_path / "x.zarr"
    t0 = time.monotonic()
    err = refused(capsys, "run", TINY, "--scheduler", address, "--out", str(out))
    assert time.monotonic() - t0 < 15
    assert f"--scheduler '{address}': no scheduler answers there" in err
    assert "running" not in err and not out.exists()


@pytest.mark.parametrize("address", ["localhost", "http://host:8786", "tcp://host"])
def test_malformed_scheduler_address_says_what_is_expected(address, capsys, tmp_path):
    err = refused(capsys, "run", TINY, "--scheduler", address, "--out", str(tmp_path / "x"))
    assert f"--scheduler {address!r}" in err and "tcp://HOST:PORT" in err


@pytest.mark.parametrize("form", [["--seed", "-1"], ["--seed=-1"]])
def test_negative_seed_is_named_before_any_work(form, capsys, tmp_path):
    out = tmp_path / "x.zarr"
    err = refused(capsys, "run", TINY, *form, "--out", str(out))
    assert "argument --seed" in err and "whole number >= 0" in err and "found -1" in err
    assert "running" not in err and not out.exists()


def test_truth_that_is_a_directory(capsys, tmp_path):
    err = refused(capsys, "run", GENERIC, "--truth", str(tmp_path), "--out", str(tmp_path / "x"))
    assert "block 'truth'" in err and "parameter 'path'" in err
    assert f"expected a file, found '{tmp_path}', which is a directory" in err


def test_truncated_level2_file_says_truncated_and_where(capsys, tmp_path):
    cut = tmp_path / "KLBB_cut"
    cut.write_bytes(LEVEL2.read_bytes()[:300_000])
    out = tmp_path / "x.zarr"
    err = refused(
        capsys, "run", GENERIC, "--truth", str(cut), "--sector", "280:282", "--out", str(out)
    )
    assert f"{cut} is truncated: the file ends at byte 300,000" in err
    assert "after its radial" in err and "block 'truth'" in err
    assert "margin" not in err
    assert not out.exists()


# ---- sectors ------------------------------------------------------------------------------------


def test_sector_narrower_than_one_beam_is_refused(capsys):
    err = refused(capsys, "validate", UNIFORM, "--sector", "240:240.4")
    assert "block 'scan'" in err and "spans 0.4 deg, less than one beam" in err
    assert "beam_spacing_deg = 1 deg" in err
    err = refused(capsys, "validate", str(REFUSED / "sector_narrower_than_a_beam.yaml"))
    assert "sector_narrower_than_a_beam.yaml:9: block 'scan'" in err
    assert "less than one beam" in err
    # One beam exactly is a sector (0.7 to 1.7 is not 0.99999 deg wide).
    assert pasim(capsys, "validate", UNIFORM, "--sector", "0.7:1.7")[0] == 0


@pytest.mark.parametrize("form", [["--sector", "-2:2"], ["--sector=-2:2"]])
def test_sector_through_north_from_negative_azimuth(form, capsys, tmp_path):
    """-2:2 is 358:2: four beams through north, stored at their true azimuths."""
    out = tmp_path / "north.zarr"
    code, err = pasim(
        capsys, "run", TINY, *form, "--set", "scan.align_to_truth=false", "--out", str(out)
    )
    assert code == 0, err
    tree = xr.open_datatree(out, engine="zarr")
    assert tree["sweep_0"]["azimuth"].values.tolist() == [358.5, 359.5, 0.5, 1.5]
    assert "azimuth_start_deg: 358.0, azimuth_stop_deg: 2.0" in tree.attrs["graph"]


def test_sector_with_equal_ends_is_refused(capsys):
    err = refused(capsys, "validate", UNIFORM, "--sector", "10:10")
    assert "--sector 10:10" in err and "holds no beam" in err and "give 0:360" in err
    err = refused(capsys, "validate", str(REFUSED / "empty_sector.yaml"))
    assert "empty_sector.yaml:9: block 'scan', parameter 'azimuth_stop_deg'" in err
    assert "starts and stops at the same azimuth" in err and "azimuth_stop_deg 360" in err
    err = refused(
        capsys,
        "validate",
        UNIFORM,
        "--set",
        "scan.azimuth_start_deg=90",
        "--set",
        "scan.azimuth_stop_deg=90",
    )
    assert "the sector 90 to 90 deg starts and stops at the same azimuth" in err
    assert pasim(capsys, "validate", UNIFORM, "--sector", "0:360")[0] == 0


# ---- size ---------------------------------------------------------------------------------------

# One beam of 2000 gates x 1024 pulses at the "combined" level: a probe of well under a second
# and 1 GB, whose I/Q (32 MB a beam) no disk of a CI machine holds 36000 times over.
BIG_BEAM = [
    UNIFORM,
    "--set",
    "weather.method=combined",
    "--set",
    "scene.gates=2000",
    "--set",
    "scan.pulses=1024",
]


def test_run_too_big_for_the_disk_is_refused_before_the_chunks(capsys, tmp_path):
    out = tmp_path / "big.zarr"
    err = refused(
        capsys,
        "run",
        *BIG_BEAM,
        "--save-iq",
        "--sector",
        "0:360",
        "--set",
        "scan.beam_spacing_deg=0.01",
        "--out",
        str(out),
    )
    assert "36000 beams" in err and "this run would write about" in err
    assert f"GiB to {out}" in err and "per beam x 36000 beams" in err and "is free there" in err
    assert not out.exists()


def test_run_too_big_for_the_memory_is_refused_before_the_chunks(capsys, tmp_path):
    """3600 beams in one chunk: hundreds of GB of working memory."""
    out = tmp_path / "big.zarr"
    err = refused(
        capsys,
        "run",
        *BIG_BEAM,
        "--sector",
        "0:360",
        "--set",
        "scan.beam_spacing_deg=0.1",
        "--chunk",
        "3600",
        "--out",
        str(out),
    )
    assert "this run would need about" in err and "GiB of memory" in err
    assert "per beam x 3600 beams per chunk" in err and "smaller --chunk" in err
    assert not out.exists()


def test_memory_error_names_the_block(tmp_path):
    """A 1.5 GiB address-space limit and a beam needing more: a message naming the block,
    not an empty MemoryError, and no store left."""
    limit = int(1.5 * 2**30)

    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    out = tmp_path / "x.zarr"
    res = subprocess.run(
        [
            *(sys.executable, "-m", "pasim_graph", "run", UNIFORM, "--sector", "0:2"),
            *("--set", "weather.method=combined", "--set", "scene.gates=4000"),
            *("--set", "scan.pulses=1024", "--out", str(out)),
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        preexec_fn=cap,
        timeout=300,
    )
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    assert "block 'weather' (channel.weather) ran out of memory" in res.stderr
    assert "smaller --chunk" in res.stderr
    assert not out.exists()


def test_save_iq_at_the_expected_level_is_refused(capsys, tmp_path):
    """The expected level draws no pulses: --save-iq would store empty cubes, so the receiver
    refuses it, names the option and the level to use, and leaves no store, nor the parent
    directories the run made for it."""
    out = tmp_path / "new" / "deeper" / "x.zarr"
    err = refused(
        capsys,
        *("run", UNIFORM, "--sector", "0:2", "--set", "weather.method=expected"),
        *("--save-iq", "--out", str(out)),
    )
    assert "block 'receiver'" in err and "--save-iq" in err and "'combined'" in err
    assert not (tmp_path / "new").exists()


# ---- small frictions ----------------------------------------------------------------------------


def test_every_run_option_has_help_text(capsys):
    """Each option of `pasim run` is documented, in the parser and in what --help prints."""
    sub = next(a for a in cli.parser()._actions if isinstance(a, argparse._SubParsersAction))
    run = sub.choices["run"]
    documented = [a for a in run._actions if a.option_strings or a.dest == "graph"]
    assert len(documented) >= 14
    for action in documented:
        assert action.help and action.help != argparse.SUPPRESS, action.dest
        assert len(action.help) > 15, (action.dest, action.help)
    try:
        main(["run", "--help"])
    except SystemExit as exc:
        assert exc.code == 0
    text = " ".join(capsys.readouterr().out.split())
    for action in documented:
        words = " ".join(action.help.split())
        assert words[:40] in text, (action.dest, words)


@pytest.mark.parametrize("levels", ["", " , "])
def test_tradeoff_with_no_level_lists_the_levels(levels, capsys):
    err = refused(capsys, "tradeoff", TINY, "--levels", levels)
    assert "--levels: no level given; the levels of this graph are expected" in err
    assert "monte_carlo" in err


def test_unknown_tradeoff_level_lists_the_ladder(capsys):
    err = refused(capsys, "tradeoff", TINY, "--levels", "bogus")
    assert "unknown level(s) bogus; the ladder is expected" in err


def test_build_prints_no_setuptools_warnings(tmp_path):
    """Building the wheel (with the installed setuptools, offline) warns of nothing: no
    deprecated license table, no data directory left out of the packages."""
    pytest.importorskip("setuptools")
    # Built from a copy: setuptools writes build/ and egg-info next to the sources.
    source = tmp_path / "src"
    skip = shutil.ignore_patterns(".*", "build", "dist", "*.egg-info", "__pycache__", "*.zarr")
    shutil.copytree(ROOT, source, ignore=skip)
    wheels = tmp_path / "wheels"
    res = subprocess.run(
        [
            *(sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation"),
            *("-v", "-w", str(wheels), "."),
        ],
        capture_output=True,
        text=True,
        cwd=source,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr
    output = res.stdout + res.stderr
    assert "Deprecat" not in output and "SetuptoolsDeprecationWarning" not in output
    assert "_Warning" not in output and "!!" not in output
    (wheel,) = wheels.glob("pasim_graph-*.whl")
    import zipfile

    names = zipfile.ZipFile(wheel).namelist()
    assert "pasim_blocks/data/KLBB20160601_150025_V06" in names
    assert "pasim_blocks/study/templates/report.html.j2" in names  # the study report's


def test_a_reader_that_stops_early_gets_no_traceback():
    """`pasim blocks --json | head -c 10`: the pipe closes while pasim still writes (its
    output is several times the 64 KiB pipe buffer); pasim stops quietly with exit 0."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "pasim_graph", "blocks", "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=ROOT,
    )
    assert proc.stdout is not None and proc.stderr is not None
    assert proc.stdout.read(10)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 0, err
    assert "Traceback" not in err and "BrokenPipe" not in err
