"""A third-party block package, installed with pip, plugs into a graph through entry points."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pasim_graph.graphfile import BlockSpec, ConnectionSpec, Endpoint, dumps, read

from ..conftest import GRAPHS, run_cli

PLUGIN = Path(__file__).parents[1] / "plugin_pkg"


@pytest.fixture(scope="module")
def plugin_env(tmp_path_factory):
    target = tmp_path_factory.mktemp("site")
    # Build from a copy: setuptools writes build/ and egg-info next to the sources.
    source = tmp_path_factory.mktemp("src") / "plugin_pkg"
    shutil.copytree(PLUGIN, source, ignore=shutil.ignore_patterns("build", "*.egg-info"))
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--target",
            str(target),
            str(source),
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    return {"PYTHONPATH": str(target)}


def _graph_with_attenuator(tmp_path, loss_db):
    spec = read(GRAPHS / "generic_radar.yaml")
    spec.blocks["radome"] = BlockSpec("example.attenuator", {"loss_db": loss_db})
    spec.connections = [c for c in spec.connections if str(c) != "weather.iq -> receiver.iq_in"]
    spec.connections += [
        ConnectionSpec(Endpoint("weather", "iq"), Endpoint("radome", "iq_in")),
        ConnectionSpec(Endpoint("radome", "iq"), Endpoint("receiver", "iq_in")),
    ]
    path = tmp_path / "with_plugin.yaml"
    path.write_text(dumps(spec))
    return path


def test_plugin_block_listed_and_broken_plugin_only_warns(plugin_env):
    res = run_cli("blocks", "--json", env=plugin_env)
    assert res.returncode == 0, res.stderr
    names = {b["type"] for b in json.loads(res.stdout)}
    assert "example.attenuator" in names and "weather" not in names
    assert "channel.weather" in names  # built-ins still load
    assert "example.broken" not in names
    assert "example.broken" in res.stderr and "failed to load" in res.stderr


def test_graph_using_broken_plugin_names_it(plugin_env, tmp_path):
    spec = read(GRAPHS / "generic_radar.yaml")
    spec.blocks["bad"] = BlockSpec("example.broken")
    path = tmp_path / "bad.yaml"
    path.write_text(dumps(spec))
    res = run_cli("validate", str(path), env=plugin_env)
    assert res.returncode == 2
    assert "block 'bad'" in res.stderr and "failed to load" in res.stderr
    assert "ImportError" in res.stderr


def test_graph_with_plugin_block_runs(plugin_env, tmp_path):
    """A 10 dB radome loss, unknown to the calibration, lowers DBZH by 10 dB (radar equation)."""
    common = ["--sector", "280:283", "--set", "scan.pulses=16", "--seed", "3"]
    with_loss = tmp_path / "loss.zarr"
    res = run_cli(
        "run",
        str(_graph_with_attenuator(tmp_path, 10.0)),
        *common,
        "--out",
        str(with_loss),
        env=plugin_env,
    )
    assert res.returncode == 0, res.stderr
    base = tmp_path / "base.zarr"
    res = run_cli("run", str(GRAPHS / "generic_radar.yaml"), *common, "--out", str(base))
    assert res.returncode == 0, res.stderr
    a = xr.open_datatree(with_loss, engine="zarr")["sweep_0"]
    b = xr.open_datatree(base, engine="zarr")["sweep_0"]
    # Compare where the echo is 30 dB above noise, so noise barely moves the estimate.
    strong = (b["SNRH"].values > 40) & np.isfinite(a["DBZH"].values)
    assert strong.sum() > 100
    diff = np.median(a["DBZH"].values[strong] - b["DBZH"].values[strong])
    assert diff == pytest.approx(-10.0, abs=0.1)
