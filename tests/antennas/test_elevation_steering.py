"""The planar array steered in elevation: an RHI of the ATD's face (80 x 80 patches) through a
uniform scene, at the noise-free `expected` level. Under boresight calibration each beam's ZDR
error is the two-way H/V ratio `pasim pattern --steer 0,EL` reports for that steering (an
independent computation: the pattern command's 2-D cut of the same block), within 0.02 dB at 0,
10 and 20 deg; under per-beam calibration it is gone at every elevation."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from pasim_graph import load
from pasim_graph.executor import LocalExecutor

from ..conftest import GRAPHS, pasim_out

ELEVATIONS = (0.0, 10.0, 20.0)


def _graph(tmp_path, calibration: str) -> str:
    text = (GRAPHS / "uniform_ideal.yaml").read_text()
    atd = (GRAPHS / "atd_radar.yaml").read_text()
    antenna = next(line for line in atd.splitlines() if line.startswith("  antenna:"))
    antenna = antenna.replace("calibration: per_beam", f"calibration: {calibration}")
    face = float(re.search(r"face_azimuth_deg: ([\d.]+)", antenna).group(1))
    scan = (
        f"  scan:     {{type: scan.rhi, params: {{azimuth_deg: {face}, elevation_start_deg: 0.0, "
        "elevation_step_deg: 10.0, elevation_stop_deg: 20.0, prt_s: 0.001, pulses: 16}}"
    )
    text = re.sub(r"  antenna:.*", antenna, text)
    text = re.sub(r"  scan:.*", scan, text)
    text = text.replace("method: covariance", "method: expected")
    path = tmp_path / f"rhi_{calibration}.yaml"
    path.write_text(text)
    return str(path)


def _zdr_error_per_beam(path: str) -> np.ndarray:
    sweep = LocalExecutor(load(path)).run()
    np.testing.assert_allclose(sweep["elevation"].values, ELEVATIONS)
    return np.nanmean(np.asarray(sweep["error_ZDR"].values, dtype=np.float64), axis=1)


def test_zdr_bias_follows_the_beam_in_elevation(tmp_path, capsys):
    path = _graph(tmp_path, "boresight")
    errors = _zdr_error_per_beam(path)
    for el, error in zip(ELEVATIONS, errors, strict=True):
        code, out, err = pasim_out(capsys, "pattern", path, "--steer", f"0,{el:g}", "--json")
        assert code == 0, err
        ratio = json.loads(out)["zdr_bias_db"]
        assert error == pytest.approx(ratio, abs=0.02), el
    assert abs(errors[0]) < 0.02 and errors[1] > 0.1 and errors[2] > errors[1] + 0.3


def test_per_beam_calibration_removes_the_bias_at_every_elevation(tmp_path):
    errors = _zdr_error_per_beam(_graph(tmp_path, "per_beam"))
    np.testing.assert_allclose(errors, 0.0, atol=0.02)
