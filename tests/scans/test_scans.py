"""The scan blocks alone: volume presets and cuts, the RHI's beams, and the sweeps a volume
declares (their parameters and start times, against sums worked out here)."""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.scans.rhi import RHIScan, rhi_elevations
from pasim_blocks.scans.vcp import PRESETS, parse_cuts, preset_key
from pasim_blocks.scans.volume_scan import VolumeScan

from pasim_graph import Chunk

from ..conftest import pasim


def test_vcp_presets_scan_the_published_elevation_angles():
    """The angles of the WSR-88D's VCP tables (VCP 212 = VCP 12's 14 angles, VCP 215's 15),
    split cuts (surveillance then Doppler) at the three lowest."""
    vcp212 = [0.5, 0.9, 1.3, 1.8, 2.4, 3.1, 4.0, 5.1, 6.4, 8.0, 10.0, 12.5, 15.6, 19.5]
    vcp215 = [0.5, 0.9, 1.3, 1.8, 2.4, 3.1, 4.0, 5.1, 6.4, 8.0, 10.0, 12.0, 14.0, 16.7, 19.5]
    for name, angles in (("vcp212", vcp212), ("vcp215", vcp215)):
        cuts = PRESETS[name]
        assert sorted({c.elevation_deg for c in cuts}) == angles
        for el in angles[:3]:
            cs, cd = [c for c in cuts if c.elevation_deg == el]
            assert cs.prt_s > 2 * cd.prt_s  # long PRT for range, short for velocity
        elevations = [c.elevation_deg for c in cuts]
        assert elevations == sorted(elevations)


def test_preset_names_are_forgiving_and_unknown_ones_are_named():
    assert preset_key("VCP 212") == preset_key("212") == "vcp212"
    problems = VolumeScan.check_config({"preset": "vcp999"}, set())
    assert len(problems) == 1 and "'vcp999'" in problems[0][1]
    assert "vcp212" in problems[0][1] and "vcp215" in problems[0][1]


def test_cuts_are_parsed_and_every_bad_cut_named():
    cuts, problems = parse_cuts("0.5 0.0031 16; 1.5 0.001 32 240:250")
    assert not problems
    assert [c.text() for c in cuts] == ["0.5 0.0031 16", "1.5 0.001 32 240:250"]
    _, problems = parse_cuts("0.5 x 16; 95 0.001 32; 1 0.001 1; 2 0.001")
    assert [p.split(" ", 2)[1] for p in problems] == ["1", "2", "3", "4"]
    assert "PRT" in problems[0] or "number" in problems[0]
    assert "elevation 95" in problems[1]


def test_volume_sweeps_follow_each_other_in_time():
    """Each cut starts when the one before has dwelt on all its beams: offsets are the
    cumulative sums of beams x pulses x PRT (worked out here)."""
    params = {
        "preset": "",
        "cuts": "0.5 0.003 16; 1.5 0.001 32; 3.4 0.002 8 244:248",
        "azimuth_start_deg": 240.0,
        "azimuth_stop_deg": 250.0,
    }
    sweeps = VolumeScan.scan_sweeps(params)
    assert [s["elevation_deg"] for s in sweeps] == [0.5, 1.5, 3.4]
    dwell = [10 * 16 * 0.003, 10 * 32 * 0.001, 4 * 8 * 0.002]
    np.testing.assert_allclose([s["time_offset_s"] for s in sweeps], [0, dwell[0], sum(dwell[:2])])
    assert sweeps[2]["azimuth_start_deg"] == 244.0 and "azimuth_start_deg" not in sweeps[0]
    block = VolumeScan(name="scan", **{**params, **sweeps[1]})
    beams = block.process({}, Chunk(beams=np.arange(3)))["beams"]
    assert np.all(beams["elevation"].values == 1.5) and int(beams["pulses"]) == 32
    expect = np.datetime64("2000-01-01T00:00:00", "ns") + np.timedelta64(480, "ms")
    assert beams["time"].values[0] == expect


def test_rhi_beams_step_in_elevation_at_one_azimuth():
    np.testing.assert_allclose(rhi_elevations(0.5, 2.0, 0.5), [0.5, 1.0, 1.5, 2.0])
    np.testing.assert_allclose(rhi_elevations(0.5, 2.2, 0.5), [0.5, 1.0, 1.5, 2.0])
    block = RHIScan(name="scan", azimuth_deg=300.0, elevation_stop_deg=10.0, elevation_step_deg=1)
    assert block.beam_count() == 10  # 0.5, 1.5, ... 9.5
    beams = block.process({}, Chunk(beams=np.arange(4, 8)))["beams"]
    np.testing.assert_allclose(beams["elevation"].values, [4.5, 5.5, 6.5, 7.5])
    assert np.all(beams["azimuth"].values == 300.0)
    assert str(beams["sweep_mode"].values) == "rhi" and float(beams["sweep_fixed_angle"]) == 300
    assert RHIScan.check_config({"elevation_start_deg": 5.0, "elevation_stop_deg": 1.0}, set())


def test_rhi_points_at_the_nearest_truth_radial(truth_dataset):
    block = RHIScan(name="scan", azimuth_deg=300.1)
    beams = block.process({"truth": truth_dataset}, Chunk(beams=np.arange(2)))["beams"]
    radials = truth_dataset["azimuth"].values
    nearest = radials[np.argmin(np.abs(radials - 300.1))]
    assert np.all(beams["azimuth"].values == nearest)


@pytest.mark.parametrize(
    "setting, named",
    [
        ("scan.preset=vcp999", "'vcp999'"),
        ("scan.cuts=0.5 0.003 16", "both preset"),
    ],
)
def test_bad_volume_exits_2_before_work(capsys, tmp_path, setting, named):
    code, err = pasim(
        capsys, "run", "graphs/generic_vcp212.yaml", "--set", setting, "--out", str(tmp_path / "s")
    )
    assert code == 2 and named in err and "Traceback" not in err
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("elevation", [-1.0, 0.5, 10.0, 45.0])
def test_ppi_scans_at_any_elevation(elevation):
    from pasim_blocks.scans.ppi import PPISector

    block = PPISector(name="scan", elevation_deg=elevation)
    beams = block.process({}, Chunk(beams=np.arange(3)))["beams"]
    assert np.all(beams["elevation"].values == elevation)
    assert float(beams["sweep_fixed_angle"]) == elevation


def test_scan_beams_lists_every_beam_of_every_sweep():
    """The beams `pasim pattern --scan` steers (``scans.scan.scan_beams``), every beam the
    run forms: an RHI's elevations, each cut of a volume, a schedule file's beams in file
    order within their sweeps."""
    from pasim_blocks.scans.scan import scan_beams
    from pasim_blocks.scans.schedule import read_schedule

    from pasim_graph import load

    from ..conftest import GRAPHS

    def beams(path, overrides=None):
        graph = load(path, overrides)
        (scan,) = graph.by_role("scan")
        return scan_beams(graph, scan)

    rhi = beams(GRAPHS / "generic_rhi.yaml")
    assert [e for _, e in rhi] == list(np.arange(0.5, 20.01, 0.5))
    volume = beams(GRAPHS / "generic_vcp212.yaml", {"scan.azimuth_stop_deg": 242.0})
    assert len(volume) == 17 * 2 and volume[0][1] == volume[2][1] == 0.5 and volume[-1][1] == 19.5
    schedule, _ = read_schedule(str(GRAPHS / "atd_schedule.csv"))
    listed = beams(GRAPHS / "atd_schedule.yaml")
    order = np.concatenate(schedule.sweeps)
    np.testing.assert_allclose([a for a, _ in listed], schedule.azimuth[order])


@pytest.mark.parametrize(
    "scan, cut, inside",
    [
        ((240.0, 330.0), "250:260", True),
        ((240.0, 330.0), "240:330", True),
        ((240.0, 330.0), "200:260", False),
        ((240.0, 330.0), "320:340", False),
        ((350.0, 20.0), "355:10", True),
        ((350.0, 20.0), "340:10", False),
        ((350.0, 20.0), "0:360", False),
        ((0.0, 360.0), "355:10", True),
    ],
)
def test_a_cuts_own_sector_must_lie_in_the_scans(scan, cut, inside):
    """The truth is read for the scan's sector: a cut's sector outside it is refused."""
    params = {"preset": "", "azimuth_start_deg": scan[0], "azimuth_stop_deg": scan[1]}
    problems = VolumeScan.check_config({**params, "cuts": f"0.5 0.003 16 {cut}"}, set())
    assert (problems == []) == inside, problems
    assert all("outside the scan's sector" in p[1] for p in problems)
