"""``pasim study`` end to end on the tiny study (two pencil beams, 8 beams of the bundled scene,
8 pulses), against independent computations from the stores it wrote, and against theory.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.study.statistics import MAD_TO_STD, bootstrap, robust_std, wrap

from pasim_graph.cli import main

from ..conftest import store_values

FIX = Path(__file__).parents[1] / "fixtures" / "study"
STUDY = FIX / "tiny_study.yaml"


def _errors(path: Path, name: str) -> np.ndarray:
    ds = xr.open_datatree(path, engine="zarr")["sweep_0"].to_dataset()
    return np.asarray(ds[f"error_{name}"].values, dtype=np.float64), ds[f"error_{name}"].attrs


@pytest.fixture(scope="module")
def study(tiny_study) -> Path:
    return tiny_study


def scores(out: Path) -> dict:
    return json.loads((out / "scores.json").read_text())


def test_the_measured_beamwidth_is_the_declared_one(study):
    # antenna.pencil declares its 3-dB beamwidth: the pattern measured for the sidelobe-free
    # stand-in must give it back (1 and 2 deg in the fixtures).
    bw = scores(study)["_study"]["beamwidths_deg"]
    assert bw["narrow/convective/-"] == pytest.approx(1.0, rel=0.02)
    assert bw["wide/convective/-"] == pytest.approx(2.0, rel=0.02)


@pytest.mark.parametrize("field", ["DBZH", "ZDR", "PHIDP", "VRADH"])
def test_std_and_bias_match_an_independent_reduction(study, field):
    s = scores(study)
    for system in ("narrow", "wide"):
        run = study / "runs" / system / "convective" / "-"
        est, attrs = _errors(run / "estimate-seed0.zarr", field)
        x = est[np.isfinite(est)]
        got = s[system]["convective"]["-"][field]
        assert got["count"] == x.size
        assert got["std"] == pytest.approx(x.std(ddof=1), rel=1e-9)
        assert got["bias"] == pytest.approx(x.mean(), abs=1e-9)
        assert got["std_ci"][0] <= got["std"] <= got["std_ci"][1]
        # Against the own expected level: a difference of two errors, on the circle.
        own, _ = _errors(run / "expected-seed0.zarr", field)
        d = est - own
        if "period" in attrs:
            p = float(attrs["period"])
            d = (d + p / 2) % p - p / 2
        d = d[np.isfinite(d)]
        assert got["own_expected"]["std"] == pytest.approx(d.std(ddof=1), rel=1e-9)
        assert got["own_expected"]["count"] == d.size


def test_common_gates_are_the_gates_every_system_scored(study):
    s = scores(study)
    a, _ = _errors(study / "runs/narrow/convective/-/estimate-seed0.zarr", "DBZH")
    b, _ = _errors(study / "runs/wide/convective/-/estimate-seed0.zarr", "DBZH")
    both = np.isfinite(a) & np.isfinite(b)
    for system, e in (("narrow", a), ("wide", b)):
        c = s[system]["convective"]["-"]["DBZH"]["common"]
        assert c["count"] == int(both.sum())
        assert c["std"] == pytest.approx(e[both].std(ddof=1), rel=1e-9)


def test_the_reference_of_the_reference_system_is_its_own_expected_level(study):
    s = scores(study)["narrow"]["convective"]["-"]["DBZH"]
    assert s["reference"]["std"] == pytest.approx(s["own_expected"]["std"])


def test_the_budget_parts_telescope_to_the_total(study):
    # est - raw = (est - own) + (own - free) + (free - short) + (short - raw) exactly; the
    # variance adds only without cross terms: within 10 % or a note saying why.
    s = scores(study)
    for system in ("narrow", "wide"):
        for field in ("DBZH", "ZDR", "RHOHV"):
            b = s[system]["convective"]["-"][field]["budget"]
            parts = [b[k] for k in ("estimator_noise", "sidelobes", "range", "main_lobe")]
            assert b["quadrature_sum"] == pytest.approx(np.sqrt(np.sum(np.square(parts))))
            assert b["adds_up"] == (abs(b["quadrature_sum"] - b["total"]) <= 0.1 * b["total"])
            assert b["adds_up"] or "correlated" in b["note"]
    # The sidelobe-free stand-in of a -32 dB pencil differs from it less than a -20 dB one.
    narrow = s["narrow"]["convective"]["-"]["DBZH"]["budget"]
    wide = s["wide"]["convective"]["-"]["DBZH"]["budget"]
    assert narrow["sidelobes"] < wide["sidelobes"]
    assert narrow["main_lobe"] < wide["main_lobe"]  # a 1 deg beam smooths less than 2 deg


def test_the_csv_holds_the_json_numbers(study):
    s = scores(study)
    with open(study / "scores.csv") as f:
        rows = list(csv.DictReader(f))
    want = s["wide"]["convective"]["-"]["ZDR"]
    for gates, against, q, v in (
        ("own", "raw", "std", want["std"]),
        ("common", "reference", "bias", want["common"]["reference"]["bias"]),
        ("own", "budget", "main_lobe", want["budget"]["main_lobe"]),
    ):
        (row,) = [
            r
            for r in rows
            if (r["system"], r["field"], r["gates"], r["against"], r["quantity"])
            == ("wide", "ZDR", gates, against, q)
        ]
        assert float(row["value"]) == pytest.approx(v)


def test_a_folder_it_did_not_write_is_left_untouched(tmp_path, capsys, study):
    (tmp_path / "notes.txt").write_text("mine")
    assert main(["study", str(STUDY), "--out", str(tmp_path)]) == 2
    assert "left untouched" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]
    # A finished study is not run over without --resume.
    assert main(["study", str(STUDY), "--out", str(study)]) == 2
    assert "--resume" in capsys.readouterr().err


def test_robust_spread_and_bootstrap_against_theory():
    rng = np.random.default_rng(1)
    x = rng.normal(0.3, 2.0, size=(400, 50))
    # For Gaussian errors 1.4826 MAD estimates sigma.
    assert robust_std(x.ravel()) == pytest.approx(2.0, rel=0.03)
    assert MAD_TO_STD == pytest.approx(1 / 0.6744897501960817, rel=1e-4)
    # Independent beams: the bootstrap interval of the std has the width of the normal
    # theory, 2 * 1.96 * sigma / sqrt(2 N), and that of the bias 2 * 1.96 * sigma / sqrt(N).
    (s_lo, s_hi), (b_lo, b_hi) = bootstrap(x, block=1)
    n = x.size
    assert s_hi - s_lo == pytest.approx(2 * 1.96 * 2.0 / np.sqrt(2 * n), rel=0.2)
    assert b_hi - b_lo == pytest.approx(2 * 1.96 * 2.0 / np.sqrt(n), rel=0.2)
    # Correlated beams (each value repeated over 5 beams): blocks of 5 see the wider spread.
    y = np.repeat(x[:80], 5, axis=0)
    narrow = np.diff(bootstrap(y, block=1)[1])[0]
    wide = np.diff(bootstrap(y, block=5)[1])[0]
    assert wide > 1.8 * narrow  # sqrt(5) = 2.24 in theory


def test_wrap_puts_differences_on_the_circle():
    d = np.array([359.0, -359.0, 181.0, 10.0])
    assert np.allclose(wrap(d, 360.0), [-1.0, 1.0, -179.0, 10.0])


def _mtimes(folder: Path) -> dict[str, float]:
    return {str(p): p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


def wait_for_runs(manifest: Path, proc: subprocess.Popen, n: int) -> None:
    """Until the study's manifest lists ``n`` finished runs, or the study ends (300 s at most)."""
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        try:
            done = len(json.loads(manifest.read_text())["runs"])
        except (OSError, ValueError):
            done = 0
        if done >= n or proc.poll() is not None:
            return
        time.sleep(0.05)


def study_command(out: Path) -> list[str]:
    """``pasim study`` of the tiny study into ``out`` in a fresh process, scores only (the
    report is tests/study/test_study_report.py's subject)."""
    return [
        sys.executable,
        "-m",
        "pasim_graph",
        "study",
        str(STUDY),
        "--out",
        str(out),
        "--no-report",
    ]


def study_process(out: Path, **popen: Any) -> subprocess.Popen:
    """:func:`study_command` started, its stderr piped."""
    return subprocess.Popen(
        study_command(out), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, **popen
    )


# Two tiny studies in fresh processes (50 s): the stop-and-resume path is checked in the
# default suite with SIGTERM (below); kill -9 with -m slow.
@pytest.mark.slow
def test_kill_9_mid_study_then_resume(tmp_path, study):
    out = tmp_path / "out"
    proc = study_process(out)
    manifest = out / "pasim-study.json"
    wait_for_runs(manifest, proc, 3)
    assert proc.poll() is None, "the study ended before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    finished = json.loads(manifest.read_text())["runs"]
    assert 3 <= len(finished) < 8
    before = {k: _mtimes(out / "runs" / k) for k in finished}
    res = subprocess.run(
        [*study_command(out), "--resume"], capture_output=True, text=True, timeout=600
    )
    assert res.returncode == 0, res.stderr
    # A run that finished between its store and the manifest is kept too.
    kept = int(res.stderr.split("keeping ")[1].split()[0])
    assert kept >= len(finished)
    for k, times in before.items():
        assert _mtimes(out / "runs" / k) == times, f"{k} was rewritten"
    assert json.loads((out / "scores.json").read_text()) == scores(study)


def test_resume_writes_again_an_array_removed_from_a_run(tmp_path, study):
    """A finished run's store that lost sweep_0/error_ZDR is not kept as finished (its ZDR
    would score as NaN): --resume writes the array again and the scores are the study's."""
    import shutil

    out = tmp_path / "out"
    shutil.copytree(study, out)
    run = next((out / "runs").rglob("estimate-seed0.zarr"))
    shutil.rmtree(run / "sweep_0" / "error_ZDR")
    assert main(["study", str(STUDY), "--out", str(out), "--resume", "--no-report"]) == 0
    assert scores(out) == scores(study)
    original = study / run.relative_to(out)
    np.testing.assert_array_equal(_errors(run, "ZDR")[0], _errors(original, "ZDR")[0])


def test_a_run_s_errors_are_read_as_it_finishes_not_by_the_last_scoring(
    tmp_path, study, monkeypatch
):
    """The study reads each computed run's errors when the run is recorded, while the runs
    in flight compute; the scoring after the last run read them all (the one-seed paper
    study on two workers: 3.5 s of reading after its last run). Two of the tiny study's
    runs computed again with --resume: each store read once, before the last scoring, which
    reads only the runs kept; the scores are the study's."""
    import shutil

    import pasim_blocks.study.reading as reading
    import pasim_blocks.study.statistics as statistics

    out = tmp_path / "out"
    shutil.copytree(study, out)
    redo = sorted((out / "runs").rglob("*-ref.zarr"))[:2]
    for run in redo:
        shutil.rmtree(run)
    events: list[tuple[str, str]] = []
    read_errors, score_study = statistics.read_errors, statistics.score_study

    def reading_errors(path):
        events.append(("read", str(Path(path).relative_to(out / "runs"))))
        return read_errors(path)

    def scoring(*args, **kwargs):
        events.append(("score", ""))
        return score_study(*args, **kwargs)

    monkeypatch.setattr(statistics, "read_errors", reading_errors)
    monkeypatch.setattr(reading, "read_errors", reading_errors)
    monkeypatch.setattr(statistics, "score_study", scoring)
    assert main(["study", str(STUDY), "--out", str(out), "--resume", "--no-report"]) == 0
    assert scores(out) == scores(study)
    computed = {str(r.relative_to(out / "runs")) for r in redo}
    last = max(i for i, e in enumerate(events) if e[0] == "score")
    before = [key for kind, key in events[:last] if kind == "read"]
    after = [key for kind, key in events[last:] if kind == "read"]
    assert sorted(before) == sorted(computed), events
    assert not computed & set(after), events
    assert len(after) == len(set(after)), events


# SIGTERM in the default suite; SIGINT takes the same path (stop_on_signals) with -m slow.
@pytest.mark.parametrize(
    "sig", [pytest.param(signal.SIGINT, marks=pytest.mark.slow), signal.SIGTERM], ids=str
)
def test_a_signalled_study_ends_with_one_line_and_resumes(tmp_path, study, sig):
    """SIGINT / SIGTERM: exit 130 / 143, one line saying how to go on, no traceback, no lock
    left in any run's store; --resume then gives the uninterrupted study's scores."""
    out = tmp_path / "out"
    proc = study_process(out, text=True)
    manifest = out / "pasim-study.json"
    wait_for_runs(manifest, proc, 2)
    assert proc.poll() is None, "the study ended before it could be signalled"
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 128 + sig, err
    assert "Traceback" not in err and f"stopped by {signal.Signals(sig).name}" in err, err
    assert "--resume" in err
    # The systems the stopped study could not score yet are named (the second had no run).
    assert "warning: system 'wide' is unscored: 0 of its" in err, err
    assert not list(out.rglob("pasim-run.lock"))
    # (the resume in this process: the signal was the subprocess's subject)
    assert main(["study", str(STUDY), "--out", str(out), "--no-report", "--resume"]) == 0
    assert json.loads((out / "scores.json").read_text()) == scores(study)


@pytest.mark.parametrize(
    "edit, words",
    [
        (lambda m: {k: v for k, v in m.items() if k != "beamwidths"}, "no 'beamwidths'"),
        (lambda m: m | {"runs": []}, "'runs' is a list"),
        (lambda m: [], "a JSON list"),
        (lambda m: m | {"format": "other/2"}, "format 'other/2'"),
    ],
)
def test_a_hand_edited_manifest_is_one_line(tmp_path, capsys, study, edit, words):
    """A manifest with "beamwidths" removed, "runs": [] or [] ended in KeyError or
    AttributeError (issue 34): --resume and --report-only refuse it in one line naming the
    file, and touch nothing."""
    manifest = json.loads((study / "pasim-study.json").read_text())
    (tmp_path / "pasim-study.json").write_text(json.dumps(edit(manifest)))
    (tmp_path / "scores.json").write_text((study / "scores.json").read_text())
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    for flag in ("--resume", "--report-only"):
        assert main(["study", str(STUDY), "--out", str(tmp_path), flag]) == 2
        err = capsys.readouterr().err
        # (--resume says first how many runs the study has: not an error)
        lines = [line for line in err.splitlines() if line.startswith("error:")]
        assert len(lines) == 1 and "Traceback" not in err, err
        assert "pasim-study.json" in lines[0] and words in lines[0], lines[0]
        assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_a_run_store_damaged_on_disk_is_named_not_a_traceback(tmp_path, capsys, study):
    """A kept run's store whose chunk bytes were damaged after it finished ended the study's
    rescoring in a traceback (DamagedStoreError was not caught): now one line naming the
    store, or the run written again; never a traceback."""
    import shutil

    copy = tmp_path / "out"
    shutil.copytree(study, copy)
    store = sorted(copy.glob("runs/*/*/*/estimate-seed*.zarr"))[0]
    chunk = sorted((store / "sweep_0" / "error_DBZH").glob("c.*"))[0]
    raw = bytearray(chunk.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    chunk.write_bytes(bytes(raw))
    code = main(["study", str(STUDY), "--out", str(copy), "--resume", "--no-report"])
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    if code == 2:
        errors = [line for line in err.splitlines() if line.startswith("error:")]
        assert len(errors) == 1 and store.name in errors[0], err
    else:
        assert code == 0, err
        assert scores(copy) == scores(study)  # the damaged run was written again


#: The in-flight study below, in a process of its own: a hang (seen once, with one client per
#: run made from the runs' threads) dumps every thread's stack and ends that process, so the
#: test fails naming where it hung instead of stalling.
IN_FLIGHT_SCRIPT = """
import faulthandler, sys
faulthandler.dump_traceback_later(float(sys.argv[1]), exit=True)
import pasim_blocks.study.inflight as inflight
inflight.runs_at_once = lambda client: int(sys.argv[2])
from pasim_graph.cli import main
sys.exit(main(sys.argv[3:]))
"""

#: Seconds the in-flight study may take (about 1-3 min on a loaded 2-core machine).
IN_FLIGHT_LIMIT_S = 480

#: Runs in flight at once (of the tiny study's 8): 4 take up both references of the first
#: system together, enough to fail with the shared scatter keys (a KeyError when one run
#: released the other's ('tx', 'pulse'), when they were scattered as a dict).
IN_FLIGHT = 4


# A two-worker cluster and the tiny study (80 s), with -m slow: the executor's chunks on a
# cluster are checked in the default suite (tests/execution/test_distributed_faults.py).
@pytest.mark.slow
def test_a_study_with_every_run_in_flight_is_the_serial_study(tmp_path, study):
    """--workers 2 with 4 of the 8 runs in flight at once on the study's one cluster and client:
    every store holds the values the serial study's holds, bit for bit, and scores.json is
    the same file; and it ends (no hang: see IN_FLIGHT_SCRIPT).

    Failed before each run's shared inputs were scattered under keys of its own: the
    runs' inputs went to the cluster under the same keys (("mf", "range_response")...), and
    the short-pulse reference was computed with another run's range response."""
    out = tmp_path / "out"
    cmd = [sys.executable, "-c", IN_FLIGHT_SCRIPT, str(IN_FLIGHT_LIMIT_S), str(IN_FLIGHT)]
    cmd += ["study", str(STUDY), "--out", str(out), "--workers", "2", "--no-report"]
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=IN_FLIGHT_LIMIT_S + 60)
    assert res.returncode == 0, (
        f"the study with {IN_FLIGHT} runs in flight failed or hung (rc {res.returncode}, "
        f"{time.perf_counter() - t0:.0f} s):\n{res.stderr[-20000:]}"
    )
    # --no-report: the scores and stores only, and the line that says how to draw it later.
    assert not (out / "report.html").exists()
    assert f"pasim study {out} --report-only draws it" in res.stderr, res.stderr
    stores = sorted(p.relative_to(study) for p in (study / "runs").rglob("*.zarr"))
    assert stores == sorted(p.relative_to(out) for p in (out / "runs").rglob("*.zarr"))
    assert len(stores) == 8
    for rel in stores:
        ours, theirs = store_values(out / rel), store_values(study / rel)
        assert ours.keys() == theirs.keys(), rel
        for name in theirs:
            assert np.array_equal(
                ours[name], theirs[name], equal_nan=ours[name].dtype.kind in "fc"
            ), (
                rel,
                name,
            )
    assert (out / "scores.json").read_text() == (study / "scores.json").read_text()
    ours_m = json.loads((out / "pasim-study.json").read_text())
    theirs_m = json.loads((study / "pasim-study.json").read_text())
    assert list(ours_m["runs"]) == list(theirs_m["runs"])  # recorded in the study's order
    for key in ("beamwidths", "patterns", "hardware"):
        assert ours_m.get(key) == theirs_m.get(key), key


def test_a_study_stopped_while_drawing_its_report_says_how_to_draw_it(
    tmp_path, capsys, study, monkeypatch
):
    """Ctrl-C while the report's figures were drawn ended in a bare "interrupted": the runs
    and scores were kept, and nothing said the report was missing or how to draw it."""
    import os
    import shutil
    import signal
    import time

    import pasim_blocks.study.report as report

    copy = tmp_path / "out"
    shutil.copytree(study, copy)
    (copy / "report.html").unlink(missing_ok=True)

    def interrupted(*args: Any, **kwargs: Any) -> Path:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5)  # the stop lands here
        raise AssertionError("not stopped")

    monkeypatch.setattr(report, "write_report", interrupted)
    code = main(["study", str(STUDY), "--out", str(copy), "--resume"])
    err = capsys.readouterr().err
    assert code == 130, err
    assert "Traceback" not in err, err
    last = err.strip().splitlines()[-1]
    assert "while drawing the report" in last and f"pasim study {copy} --report-only" in last
    assert (copy / "scores.json").is_file() and not (copy / "report.html").exists()
