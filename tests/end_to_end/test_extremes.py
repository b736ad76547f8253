"""Numerical extremes, each through `pasim run` on the uniform scene (docs/extremes.md).

No crash and no silent NaN: every scored gate either has an estimate or is counted as
unestimated, and the outcome of each extreme is checked against what theory says it must be.
"""

from __future__ import annotations

import json
import math

import pytest

from ..conftest import GRAPHS, pasim_out

UNIFORM = str(GRAPHS / "uniform_ideal.yaml")
CORE = str(GRAPHS / "core_contamination.yaml")
SMALL = ["--set", "scan.azimuth_stop_deg=10"]  # 10 beams x 100 gates


def scores(capsys, tmp_path, graph, *sets):
    """``pasim run`` then ``pasim score --json``, in this process (the CLI's own entry point:
    its error handling and warning lines are the ones a user sees)."""
    out = tmp_path / f"run{len(list(tmp_path.iterdir()))}.zarr"
    args = [x for s in sets for x in ("--set", s)]
    # a --set of the sector's stop replaces SMALL's (the same --set twice is refused)
    small = [] if any(s.startswith("scan.azimuth_stop_deg=") for s in sets) else SMALL
    code, _, err = pasim_out(capsys, "run", graph, *small, *args, "--out", str(out))
    assert code == 0, err
    # No warning line of any kind (the CLI prints each Python warning as "warning: ...").
    assert "Traceback" not in err and "warning" not in err.lower(), err
    code, stdout, err = pasim_out(capsys, "score", str(out), "--json")
    assert code == 0, err
    result = json.loads(stdout)
    for s in result.values():  # every scored gate is accounted for
        assert s["count"] + s["unestimated"] == s["scored_gates"]
    return result


@pytest.mark.parametrize("width", [0.0, 0.01])
def test_zero_and_tiny_spectrum_width(capsys, tmp_path, width):
    """Width 0 makes eq. 13 singular; the 64 pulses are then one sample, and the power
    estimate is exponential: std of 10 log10 of an exponential variable = 5.57 dB (theory).

    A gate is undefined when its one echo sample falls below the noise estimate's spread:
    P(|a|^2 < 3 sigma_N) = 1 - exp(-(3 / sqrt(64)) / SNR), 0.37 % of gates at SNR 20 dB, so
    a few of the 1,000 gates may be, never more than three times that. The widths are taken
    as given (``width_model: truth``): by default the dish's scan modulation widens them."""
    s = scores(
        capsys, tmp_path, UNIFORM, f"scene.spectrum_width_ms={width}", "weather.width_model=truth"
    )
    n = s["DBZH"]["scored_gates"]
    assert s["DBZH"]["unestimated"] <= 3 * n * (1 - math.exp(-(3 / 8) / 100))
    assert s["DBZH"]["std"] == pytest.approx(5.57, rel=0.1)


def test_rho_exactly_one_and_truth_above_one(capsys, tmp_path):
    """rho_hv = 1 makes V fully determined by H: the estimate sits at 1 up to noise (SNR 20 dB
    gives a std of a few 1e-3). A truth above 1 (NEXRAD reports up to 1.05) is drawn as 1, so
    the scores show the truth's excess as a bias, honestly."""
    one = scores(capsys, tmp_path, UNIFORM, "scene.cross_correlation_ratio=1.0")
    assert abs(one["RHOHV"]["bias"]) < 0.002 and one["RHOHV"]["std"] < 0.005
    above = scores(capsys, tmp_path, UNIFORM, "scene.cross_correlation_ratio=1.05")
    assert above["RHOHV"]["bias"] == pytest.approx(-0.05, abs=0.003)


def test_minus_30_and_80_dbz_side_by_side(capsys, tmp_path):
    """110 dB of dynamic range in one sector: runs; the weak gates next to the core are
    dominated by the core's leakage (positive bias), the noise-only ones are counted."""
    s = scores(
        capsys,
        tmp_path,
        CORE,
        "scene.reflectivity_dbz=-30",
        "scene.core_dbz=80",
        "scan.azimuth_stop_deg=30",
    )
    assert s["DBZH"]["count"] > 1000
    assert s["DBZH"]["bias"] > 1.0


def test_snr_minus_20_db_masks_negative_powers(capsys, tmp_path):
    """At SNR -20 dB the noise-corrected power is negative in about half the gates (theory:
    P(S_hat <= 0) ~ 0.5 when the signal is far below the noise's fluctuation): they are masked
    and counted, not NaN in the statistics."""
    s = scores(capsys, tmp_path, UNIFORM, "receiver.snr_db=-20")
    n = s["DBZH"]["scored_gates"]
    assert 0.3 * n < s["DBZH"]["unestimated"] < 0.7 * n
    assert math.isfinite(s["DBZH"]["std"])


@pytest.mark.parametrize("pulses", [2, 1024])
def test_two_and_1024_pulses(capsys, tmp_path, pulses):
    """M = 2 leaves one lag-1 product; M = 1024 needs a 1024 x 1024 factorisation. Both run;
    the power std falls with M (theory: roughly 1/sqrt(independent samples))."""
    s = scores(capsys, tmp_path, UNIFORM, f"scan.pulses={pulses}")
    assert s["WRADH"]["count"] > 0
    if pulses == 1024:
        assert s["DBZH"]["std"] < 0.5
    else:
        assert s["DBZH"]["std"] > 3.0


def test_velocity_beyond_nyquist(capsys, tmp_path):
    """40 m/s with a Nyquist velocity of 26.8 m/s (PRT 1 ms, 10.7 cm) aliases to -13.6 m/s;
    the scorer differences on the circle, so the error is still about zero."""
    s = scores(capsys, tmp_path, UNIFORM, "scene.velocity_ms=40")
    assert abs(s["VRADH"]["bias"]) < 0.1


@pytest.mark.parametrize("phidp", [359.5, -10.0, 370.0])
def test_phidp_across_360(capsys, tmp_path, phidp):
    """Estimates near 0/360 wrap; errors are differenced on the circle, so no 360-deg jumps."""
    s = scores(capsys, tmp_path, UNIFORM, f"scene.differential_phase_deg={phidp}")
    assert abs(s["PHIDP"]["bias"]) < 0.5 and s["PHIDP"]["std"] < 5.0


def test_all_masked_sector(capsys, tmp_path):
    """No echo anywhere: the run completes, scores nothing and says so."""
    out = tmp_path / "run.zarr"
    code, stdout, err = pasim_out(
        capsys, "run", UNIFORM, *SMALL, "--set", "scene.masked=true", "--out", str(out)
    )
    assert code == 0, err
    assert "no gate met the scoring rule" in stdout  # the score table's own note
    s = json.loads(pasim_out(capsys, "score", str(out), "--json")[1])
    assert all(v["count"] == 0 and v["bias"] is None for v in s.values())
