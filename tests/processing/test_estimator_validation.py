"""Estimator statistics of the whole chain on the uniform scene against a reference.

The reference is independent of the simulator's signal chain: `theory.monte_carlo_statistics`
applies the pulse-pair estimators to dwells drawn from the exact joint H-V covariance (no
scene, antenna, weather channel or receiver); the delta-method theory is checked to agree
with it where it is valid (tests/processing/test_theory.py). The full 16-point grid of issue 3
runs in benchmarks/validate_estimators.py; its results are in docs/validation.md.
"""

from __future__ import annotations

import json

import pytest

from tests.reference.theory import compare_with_reference, monte_carlo_statistics

from ..conftest import GRAPHS, pasim_result

UNIFORM = str(GRAPHS / "uniform_ideal.yaml")
LAMBDA = 299_792_458.0 / 2.8e9


def run_scores(capsys, tmp_path, name, pulses, width, snr, rho, method="covariance"):
    out = tmp_path / f"{name}.zarr"
    sets = {
        "scan.pulses": pulses,
        "scan.prt_s": 1e-3,
        "scene.spectrum_width_ms": width,
        "receiver.snr_db": snr,
        "scene.cross_correlation_ratio": rho,
        "weather.method": method,
    }
    args = [x for k, v in sets.items() for x in ("--set", f"{k}={v}")]
    res = pasim_result(capsys, "run", UNIFORM, *args, "--out", str(out))
    assert res.returncode == 0, res.stderr
    return json.loads(pasim_result(capsys, "score", str(out), "--json").stdout)


@pytest.mark.parametrize(
    ("pulses", "width", "snr", "rho"), [(32, 2.0, 10.0, 0.9), (32, 4.0, 30.0, 0.98)]
)
def test_uniform_scene_matches_the_reference(capsys, tmp_path, pulses, width, snr, rho):
    """All six stds within 15 % and biases within tolerance (see compare_with_reference)."""
    score = run_scores(capsys, tmp_path, "cov", pulses, width, snr, rho)
    reference = monte_carlo_statistics(
        pulses, 1e-3, LAMBDA, width, 5.0, snr, 1.0, rho, 30.0, gates=20_000, seed=1
    )
    rows = compare_with_reference(score, reference)
    assert len(rows) == 6
    bad = {k: v for k, v in rows.items() if not v["ok"]}
    assert not bad, bad


def test_monte_carlo_and_covariance_methods_agree(capsys, tmp_path):
    """The paper's two time-series methods give the same stds within 10 % (issue 3)."""
    args = (32, 4.0, 30.0, 0.98)
    cov = run_scores(capsys, tmp_path, "cov", *args)
    mc = run_scores(capsys, tmp_path, "mc", *args, method="monte_carlo")
    for name in ("DBZH", "VRADH", "WRADH", "ZDR", "RHOHV", "PHIDP"):
        assert mc[name]["std"] == pytest.approx(cov[name]["std"], rel=0.10), name
