"""GMAP (``processor.spectral``, Siggia and Passarelli 2004) through the chain, checked two
ways on the I/Q the chain produces for a uniform scene (30 dBZ, 5 m/s, width 2 m/s) under a
uniform clutter map (``graphs/uniform_clutter.yaml``, window ``auto``):

* against an independent computation: ``tests.reference.gmap``, a GMAP written apart from
  the simulator's (per gate, explicit DFT sums, its own clutter model and window choice),
  applied to the same receiver I/Q with the same noise power. The mean DBZH and VRADH
  errors must agree within 0.3 dB and 0.2 m/s at every point of the grid SNR 0, 10, 20,
  30 dB x clutter-to-signal ratio 0-50 dB (two points by default; the whole grid is marked
  slow; its table is in docs/doppler.md, from ``benchmarks/gmap_grid.py``);
* against the truth: at SNR 10 dB under 40 dB of clutter (seed 48, the case where the
  former filter's refill, its width taken from clipped noise, pulled the velocity 1.3 m/s
  toward zero) the VRADH bias is under 0.3 m/s and the DBZH bias under 1 dB;
* against the unfiltered estimate: with the clutter at -30 dBZ (none to speak of) GMAP
  moves the mean DBZH and VRADH by less than a tenth of the estimator's noise (the
  standard deviation of the unfiltered errors over the gates).
"""

from __future__ import annotations

import numpy as np
import pytest

from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graph import load
from tests.gmap_grid import CSRS_DB, GRAPH, SNRS_DB, TRUTH_DBZ, grid_point, summary


def check_point(snr_db: float, csr_db: float, beams: int) -> None:
    s = summary(grid_point(snr_db, TRUTH_DBZ + csr_db, seed=7, beams=beams))
    assert s["both_nan"] == 1.0  # the same gates without an estimate
    assert s["gates"] > 0.9
    assert abs(s["dbz_project"] - s["dbz_independent"]) < 0.3, s
    assert abs(s["vel_project"] - s["vel_independent"]) < 0.2, s


@pytest.mark.parametrize(("snr_db", "csr_db"), [(20.0, 10.0), (10.0, 40.0)])
def test_gmap_matches_independent_gmap(snr_db, csr_db):
    check_point(snr_db, csr_db, beams=2)


@pytest.mark.slow
def test_gmap_matches_independent_gmap_full_grid():
    for snr_db in SNRS_DB:
        for csr_db in CSRS_DB:
            check_point(snr_db, csr_db, beams=4)


def run(overrides: dict, seed: int = 48):
    return LocalExecutor(load(GRAPH, overrides), RunOptions(seed=seed)).run()


def test_gmap_velocity_unbiased_at_snr_10db():
    """``pasim run graphs/uniform_clutter.yaml --set receiver.snr_db=10 --seed 48``."""
    sweep = run({"receiver.snr_db": 10.0})
    assert abs(np.nanmean(sweep["error_VRADH"].values)) < 0.3
    assert abs(np.nanmean(sweep["error_DBZH"].values)) < 1.0


def test_gmap_leaves_weather_alone_without_clutter():
    """Clutter at -30 dBZ under 30 dBZ weather at SNR 10 dB: GMAP against no filter, with
    the same windows, on the same I/Q. The mean shift must be under a tenth of the
    estimator's own noise (the gates' standard deviation: 3.3 dB and 1.5 m/s here); the
    former filter moved them by -0.32 dB and -0.37 m/s."""
    base = {"receiver.snr_db": 10.0, "clutter.clutter_dbz": -30.0}
    filtered = run(base)
    plain = run(base | {"spectral.clutter_filter": "none"})
    for name in ("DBZH", "VRADH"):
        noise = np.nanstd(plain[f"error_{name}"].values)
        shift = np.nanmean(filtered[name].values - plain[name].values)
        assert abs(shift) < 0.1 * noise, (name, shift, noise)
