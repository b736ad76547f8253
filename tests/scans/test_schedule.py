"""scan.schedule: beams from a CSV file, grouped into sweeps, timed as the file's timeline, and
bad files refused before any work, naming the file, row and column."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.scans.schedule import ScheduledScan, read_schedule

from pasim_graph import Chunk

from ..conftest import GRAPHS, pasim, pasim_out

HEADER = "azimuth_deg,elevation_deg,pulses,prt_s"


def _csv(tmp_path, *lines, name="s.csv"):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def test_beams_group_by_pulses_and_prt_and_follow_the_timeline(tmp_path):
    """Without a sweep column, equal (pulses, PRT) make a sweep; each dwell starts when the one
    before it in the file ends (cumulative sums worked out here)."""
    path = _csv(
        tmp_path,
        HEADER,
        "300,0.5,16,0.003",
        "301,2.0,48,0.001",
        "305,0.5,16,0.003",
        "302,4.5,48,0.001",
    )
    schedule, problems = read_schedule(path)
    assert not problems and schedule is not None
    assert [list(s) for s in schedule.sweeps] == [[0, 2], [1, 3]]
    dwell = [16 * 0.003, 48 * 0.001, 16 * 0.003, 48 * 0.001]
    np.testing.assert_allclose(schedule.offset, np.concatenate([[0], np.cumsum(dwell)[:-1]]))
    assert ScheduledScan.scan_sweeps({"path": path}) == [{"sweep_index": 0}, {"sweep_index": 1}]
    block = ScheduledScan(name="scan", path=path, sweep_index=1)
    beams = block.process({}, Chunk(beams=np.arange(2)))["beams"]
    np.testing.assert_allclose(beams["azimuth"].values, [301, 302])
    np.testing.assert_allclose(beams["elevation"].values, [2.0, 4.5])
    assert int(beams["pulses"]) == 48 and str(beams["sweep_mode"].values) == "electronic_steering"
    t0 = np.datetime64("2000-01-01T00:00:00", "ns")
    assert beams["time"].values[1] == t0 + np.timedelta64(round(sum(dwell[:3]) * 1e9), "ns")
    assert "scan_rate" not in beams  # nothing rotates


def test_a_sweep_column_decides_the_grouping(tmp_path):
    path = _csv(
        tmp_path,
        HEADER + ",sweep",
        "300,0.5,16,0.003,low",
        "300,1.5,16,0.003,high",
        "310,0.5,16,0.003,low",
    )
    schedule, _ = read_schedule(path)
    assert [list(s) for s in schedule.sweeps] == [[0, 2], [1]]
    mixed = _csv(tmp_path, HEADER + ",sweep", "300,0.5,16,0.003,a", "300,1.5,32,0.003,a", name="m")
    _, problems = read_schedule(mixed)
    assert len(problems) == 1 and "sweep 'a'" in problems[0] and "mixes" in problems[0]


@pytest.mark.parametrize(
    "lines, named",
    [
        ((HEADER, "300,0.5,16,0.003", "400,0.5,16,0.003"), ["row 3, column 'azimuth_deg'"]),
        (("azimuth_deg,pulses,prt_s", "300,16,0.003"), ["row 1", "elevation_deg"]),
        (
            (HEADER, "300,abc,16,0.003", "300,0.5,16,0.5", "300,95,2.5,0.001"),
            [
                "row 2, column 'elevation_deg'",
                "row 3, column 'prt_s'",
                "row 4, column 'elevation_deg'",
                "row 4, column 'pulses'",
            ],
        ),
    ],
    ids=["angle out of range", "missing column", "non-numbers, every problem at once"],
)
def test_bad_schedule_exits_2_naming_file_row_and_column(capsys, tmp_path, lines, named):
    path = _csv(tmp_path, *lines)
    out = tmp_path / "store"
    code, err = pasim(
        capsys, "run", str(GRAPHS / "atd_schedule.yaml"), "--set", f"scan.path={path}",
        "--out", str(out),
    )  # fmt: skip
    assert code == 2, err
    assert "Traceback" not in err and path in err
    for text in named:
        assert text in err
    assert not out.exists()  # refused before any work


def _run_schedule(capsys, graph, out, *extra):
    return pasim_out(
        capsys, "run", str(graph), "--set", "weather.method=expected",
        "--set", "weather.range_folding=false", "--outputs", "DBZH", "--out", str(out), *extra,
    )  # fmt: skip


def test_a_schedule_runs_end_to_end(tmp_path, capsys):
    """The generic radar on the example schedule file: two sweeps (surveillance and storm)
    whose beams interleave in time; time on target = sum of the file's dwells."""
    text = (GRAPHS / "generic_radar.yaml").read_text()
    scan = next(line for line in text.splitlines() if line.startswith("  scan:"))
    csv_path = GRAPHS / "atd_schedule.csv"
    graph = tmp_path / "g.yaml"
    graph.write_text(
        text.replace(scan, f"  scan:     {{type: scan.schedule, params: {{path: {csv_path}}}}}")
    )
    out = tmp_path / "store"
    code, stdout, err = _run_schedule(capsys, graph, out)
    assert code == 0, err
    assert "25 beams in 2 sweeps" in err
    schedule, _ = read_schedule(str(csv_path))
    total = float((schedule.pulses * schedule.prt).sum())
    assert f"volume (2 sweeps, time on target {total:.3f} s)" in stdout
    tree = xr.open_datatree(out, engine="zarr")
    surveillance, storm = tree["sweep_0"]["time"].values, tree["sweep_1"]["time"].values
    assert surveillance.min() < storm.min() < surveillance.max()  # interleaved
    np.testing.assert_allclose(tree["sweep_1"]["elevation"].values[:2], [1.5, 1.5])


@pytest.mark.slow
def test_atd_runs_its_schedule_file(tmp_path, capsys):
    """The example graph itself (the 80 x 80 planar array: about 20 s)."""
    code, stdout, err = _run_schedule(capsys, GRAPHS / "atd_schedule.yaml", tmp_path / "s")
    assert code == 0, err
    assert "volume (2 sweeps" in stdout


def test_a_byte_order_mark_is_not_part_of_the_header(tmp_path):
    # Spreadsheets write UTF-8 CSV with a BOM: it was read as part of the first column's name,
    # and the file refused for "missing column(s) azimuth_deg".
    path = tmp_path / "excel.csv"
    path.write_bytes(b"\xef\xbb\xbf" + f"{HEADER}\n300,0.5,16,0.003\n".encode())
    schedule, problems = read_schedule(str(path))
    assert problems == [] and schedule is not None
    assert schedule.azimuth.tolist() == [300.0]


def test_a_column_given_twice_is_refused_by_name(tmp_path):
    # The first of the two was taken, silently.
    path = _csv(tmp_path, HEADER + ",elevation_deg", "300,0.5,16,0.003,1.5")
    schedule, problems = read_schedule(path)
    assert schedule is None
    assert problems == [
        f"{path}: row 1 (the header): column 'elevation_deg' appears 2 times; give each column once"
    ]
