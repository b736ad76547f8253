"""A study of a small planar array (16 x 16 patches, face at 285 deg) over 84 deg of the bundled
scene: its ZDR bias along azimuth under boresight and per-beam calibration against its two-way
H/V ratio (paper section 3.3.2, figures 9e-11e), and its phase-shifter bits swept (design
curves). Checked against theory (the bias follows the ratio dB for dB; a b-bit phase shifter
raises quantisation lobes), against ``pasim pattern`` and against reductions of the stores.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.study.calibration import MIN_GATES
from pasim_blocks.study.design_curves import NEGLIGIBLE_SHARE, monotone, stops_mattering

from pasim_graph.cli import main

from .test_study_report import open_in_chromium

FIX = Path(__file__).parents[1] / "fixtures" / "study"
STUDY = FIX / "array_study.yaml"

# The study behind every test here is 17 runs (about 160 s on the 2-core machine): -m slow.
# The calibration and phase-bit physics it rests on are checked in the default suite
# (per-beam calibration: tests/antennas/test_elements.py; phase-shifter bits:
# tests/antennas/test_electronics.py).
pytestmark = pytest.mark.slow
FACE_DEG = 285.0  # small_planar.yaml's face_azimuth_deg


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("arrays") / "out"
    assert main(["study", str(STUDY), "--out", str(out)]) == 0
    return out


def scores(out: Path) -> dict:
    return json.loads((out / "scores.json").read_text())


def calibration(out: Path) -> dict:
    return scores(out)["planar"]["convective"]["-"]["ZDR"]["calibration"]


def test_a_calibrated_array_is_also_run_under_the_other_calibration(study):
    run = study / "runs/planar/convective/-"
    assert (run / "calibration_boresight-seed0.zarr").is_dir()
    graph = xr.open_datatree(run / "calibration_boresight-seed0.zarr", engine="zarr").attrs
    assert "calibration: boresight" in graph["graph"]
    # Only at the unswept point: a design curve is of the system as built.
    assert not list((study / "runs/planar_bits").rglob("calibration_*"))


def test_the_boresight_bias_follows_the_hv_ratio_and_per_beam_calibration_flattens_it(study):
    """Theory (paper section 3.3.2, Zhang et al.): with the broadside radar constant a planar
    face's ZDR bias is the two-way H/V power ratio of each beam, dB for dB; a radar constant per
    beam from its own pattern removes it."""
    cal = calibration(study)
    assert cal["own"] == "per_beam"
    ratio = np.asarray(cal["hv_ratio_db"])
    assert np.ptp(ratio) > 2.0  # the patch's H/V mismatch grows to > 2 dB at 40 deg off
    bore, per_beam = cal["against_ratio"]["boresight"], cal["against_ratio"]["per_beam"]
    assert bore["correlation"] >= 0.9
    assert bore["slope"] == pytest.approx(1.0, abs=0.2)
    assert abs(per_beam["slope"]) < 0.2
    assert per_beam["azimuth_std_db"] < 0.4 * bore["azimuth_std_db"]


def test_the_profiles_are_the_stores_beam_means(study):
    """Independent reduction: each beam's mean scored ZDR error of the two runs' stores."""
    cal = calibration(study)
    run = study / "runs/planar/convective/-"
    for kind, store in (("boresight", "calibration_boresight"), ("per_beam", "estimate")):
        ds = xr.open_datatree(run / f"{store}-seed0.zarr", engine="zarr")["sweep_0"]
        err = np.asarray(ds["error_ZDR"].values, dtype=np.float64)
        n = np.isfinite(err).sum(axis=1)
        with np.errstate(invalid="ignore"):
            want = np.where(n >= MIN_GATES, np.nanmean(err, axis=1), np.nan)
        assert np.allclose(cal["profiles_db"][kind], want, equal_nan=True)
        assert np.allclose(cal["azimuth_deg"], ds["azimuth"].values)


@pytest.mark.parametrize("beam", [0, -1])
def test_the_hv_ratio_is_the_one_pasim_pattern_measures(study, capsys, beam):
    """``pasim pattern --steer`` measures the ratio at the 2-D peak of the H beam, the study at
    the beam's steering direction: the element pattern's slope squints the peak a little
    towards broadside, where the ratio is smaller, so the two agree within 0.2 dB at 39 deg off
    broadside (and the study's is the larger)."""
    s = scores(study)
    cal = calibration(study)
    pattern = s["_study"]["patterns"]["planar/convective/-"]
    az = cal["azimuth_deg"][beam]
    steer = f"{az - FACE_DEG:.6f},0.5"
    assert main(["pattern", str(FIX / "small_planar.yaml"), "--steer", steer, "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    ratio = pattern["hv_ratio_db"][beam]
    assert ratio == pytest.approx(figures["zdr_bias_db"], abs=0.2)
    assert abs(ratio) >= abs(figures["zdr_bias_db"])
    # The calibration's ratio is relative to broadside's, which the boresight constant takes out
    # (zero for a patch, whose H and V patterns agree at broadside).
    assert abs(pattern["hv_ratio_broadside_db"]) < 0.01
    assert cal["hv_ratio_db"][beam] == pytest.approx(ratio - pattern["hv_ratio_broadside_db"])


def test_fewer_bits_raise_the_peak_sidelobe(study, capsys):
    """Theory: b-bit phase shifters on a progressive phase make periodic errors whose
    quantisation lobes stand near -6 b dB (Mailloux); 8 bits leave the continuous-phase array's
    sidelobes. The continuous array measured independently with ``pasim pattern``."""
    sweep = scores(study)["_study"]["sweeps"]["planar_bits"]["convective"]
    assert sweep["parameter"] == "antenna.phase_bits" and sweep["values"] == [2.0, 3.0, 8.0]
    two, three, eight = sweep["peak_sidelobe_db"]
    assert two > three > eight
    assert sweep["peak_sidelobe_trend"] == {"monotone": True, "direction": "falling", "against": []}
    patterns = scores(study)["_study"]["patterns"]["planar_bits/convective/antenna.phase_bits=8"]
    continuous = []
    for az in patterns["sidelobe_beams_deg"]:
        steer = f"{az - FACE_DEG:.6f},0.5"
        graph = str(FIX / "small_planar.yaml")
        assert (
            main(["pattern", graph, "--steer", steer, "--json", "--set", "antenna.phase_bits=0"])
            == 0
        )
        continuous.append(json.loads(capsys.readouterr().out)["peak_sidelobe_db"])
    assert eight == pytest.approx(float(np.mean(continuous)), abs=1.0)
    assert two > eight + 10.0  # 2-bit lobes near -12 dB against sidelobes near -28 dB


def test_the_sweep_summary_holds_each_points_budget(study):
    s = scores(study)
    sweep = s["_study"]["sweeps"]["planar_bits"]["convective"]
    for name, f in sweep["fields"].items():
        for i, b in enumerate((2, 3, 8)):
            budget = s["planar_bits"]["convective"][f"antenna.phase_bits={b}"][name]["budget"]
            parts = [budget[k] for k in ("estimator_noise", "sidelobes", "range", "main_lobe")]
            share = budget["sidelobes"] ** 2 / np.sum(np.square(parts))
            assert f["sidelobes"][i] == budget["sidelobes"]
            assert f["sidelobes_share"][i] == pytest.approx(share)
            lo, hi = f["sidelobes_ci"][i]
            assert lo <= budget["sidelobes"] <= hi
        stop = f["stops_mattering"]
        assert stop["matters_at"] == [
            x
            for x, sh in zip((2, 3, 8), f["sidelobes_share"], strict=True)
            if sh >= NEGLIGIBLE_SHARE
        ]


def test_the_report_draws_and_says_it(study):
    html = (study / "report.html").read_text()
    assert 'alt="ZDR bias of planar along azimuth' in html
    assert 'table class="calibration"' in html
    assert 'alt="peak sidelobe and error budget of planar_bits' in html
    assert "Peak sidelobe: falls from" in html
    assert "DBZH, sidelobe part of the budget" in html


def test_monotone_within_intervals_by_construction():
    ci = [[9.0, 11.0], [7.0, 9.5], [4.0, 6.0]]
    assert monotone([10.0, 8.0, 5.0], ci) == {
        "monotone": True,
        "direction": "falling",
        "against": [],
    }
    # A step up whose interval clears the one before it goes against a falling trend...
    assert monotone([10.0, 13.0, 5.0], [[9, 11], [12, 14], [4, 6]])["against"] == [0]
    # ...but not when the intervals overlap.
    assert monotone([10.0, 10.5, 5.0], [[9, 11], [9.5, 11.5], [4, 6]])["monotone"] is True
    assert monotone([math.nan, 1.0], [[math.nan] * 2, [0.5, 1.5]])["monotone"] is None


def test_stops_mattering_by_construction():
    t = NEGLIGIBLE_SHARE
    got = stops_mattering([3, 4, 5, 6], [4 * t, 2 * t, t / 2, t / 4])
    assert got["value"] == 5 and got["matters_at"] == [3, 4]
    assert stops_mattering([3, 4], [t / 2, t / 3])["value"] == 3  # negligible everywhere
    assert stops_mattering([3, 4], [3 * t, 2 * t])["value"] is None  # matters everywhere
    # A share that shrinks as the parameter falls (a larger cylinder, say) is walked the other way.
    assert stops_mattering([1, 2, 3], [t / 4, t / 2, 3 * t])["value"] == 2


def test_the_new_figures_in_chromium(study):
    seen = open_in_chromium(study / "report.html")
    assert seen["errors"] == [] and seen["failed"] == []
    assert seen["widths"] and all(w > 0 for w in seen["widths"])
    assert seen["rows"]["calibration"] == 2  # planar under per-beam and boresight
    assert any(a.startswith("ZDR bias of planar") for a in seen["alts"])
    assert any(a.startswith("peak sidelobe and error budget") for a in seen["alts"])
    assert seen["rows"]["hardware"] >= 10  # pattern, waveform and spectrum figures
    assert sum(a.startswith("Antenna pattern cut, range response") for a in seen["alts"]) == 2


def test_the_csv_holds_the_calibration_numbers(study):
    import csv

    cal = calibration(study)
    with open(study / "scores.csv") as f:
        rows = [r for r in csv.DictReader(f) if (r["system"], r["field"]) == ("planar", "ZDR")]
    got = {(r["against"], r["quantity"]): r["value"] for r in rows}
    assert float(got[("hv_ratio", "std_db")]) == pytest.approx(cal["hv_ratio_std_db"])
    assert set(cal["against_ratio"]) == {"boresight", "per_beam"}
    for kind, fit in cal["against_ratio"].items():
        for q in ("correlation", "slope", "azimuth_std_db", "mean_db", "beams"):
            assert float(got[(f"calibration_{kind}", q)]) == pytest.approx(fit[q])


def test_the_hardware_figures_are_the_commands_own(study, capsys):
    """Each system's pattern, waveform and spectrum figures in the study are what
    ``pasim pattern``, ``pasim waveform`` and ``pasim spectrum`` print for its graph, run
    independently here (the beam steered from the face to the sector's centre, 285 deg)."""
    hw = json.loads((study / "pasim-study.json").read_text())["hardware"]
    assert set(hw) == {"planar", "planar_bits"}
    planar = hw["planar"]
    graph = str(FIX / "small_planar.yaml")
    for command, part in (
        (["pattern", graph, "--steer", f"{285.0 - FACE_DEG},0.5", "--span", "60"], "pattern"),
        (["waveform", graph], "waveform"),
        (["spectrum", graph], "spectrum"),
    ):
        assert main([*command, "--json"]) == 0
        printed = json.loads(capsys.readouterr().out)
        for key, value in planar[part]["figures"].items():
            if isinstance(value, float) and math.isfinite(value):
                assert printed[key] == pytest.approx(value, rel=1e-9, abs=1e-12), (part, key)
            elif not isinstance(value, float):
                assert printed.get(key) == value, (part, key)
    # The swept system is measured at its first point, and says so.
    assert hw["planar_bits"]["point"] == "antenna.phase_bits=2"
    rows = {r[0]: r[1:] for r in _hardware_rows(study)}
    assert (
        rows["peak sidelobe (dB)"][0] == f"{planar['pattern']['figures']['peak_sidelobe_db']:.1f}"
    )
    assert rows["RSEC emission mask"][0].startswith(
        "passes" if planar["spectrum"]["figures"]["passes"] else "fails"
    )


def _hardware_rows(study: Path) -> list[list[str]]:
    from .test_study_report import page

    return page(study).tables["hardware"][1:]
