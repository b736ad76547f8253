"""Multiple-trip echoes (range folding) in the weather channel, and the scorer's overlay flag.

What each test compares against:

* the issue's case: a truth with a single 40 dBZ storm at 190-210 km, PRT 1 ms (unambiguous
  range r_a = 149.9 km): the storm shows at 40-60 km with the power the radar equation gives
  at its true range, Z (r / (r + r_a))^2 (an independent computation: the gate calibrated for
  r sees the echo from r + r_a), within 0.5 dB on the mean power over its interior gates and
  the 20 beams; no gate at or beyond r_a holds a sample;
* the overlay flag: the scorer's flagged gates against the other trips' power computed here
  from the truth with the same radar equation (a 20 dBZ background to 252 km), away from the
  edges where the range response blurs it; flagged gates are not scored and `pasim score`
  reports their number apart;
* range folding off: the storm's echo is absent from the near gates.
"""

from __future__ import annotations

import numpy as np

from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graph import load
from pasim_graph.store import summarize

from ..conftest import GRAPHS

R_A = 299_792_458.0 * 1e-3 / 2


def run(overrides: dict | None = None):
    graph = load(GRAPHS / "range_folding.yaml", overrides or {})
    return LocalExecutor(graph, RunOptions(seed=4)).run()


def test_storm_at_200_km_folds_to_50_km():
    sweep = run()
    r = sweep["range"].values
    z = sweep["DBZH"].values
    inner = (r > 190e3 - R_A + 2e3) & (r < 210e3 - R_A - 2e3)
    predicted = 40.0 - 20 * np.log10((r[inner] + R_A) / r[inner])
    # Mean power over the storm's 64 interior gates x 20 beams against the prediction.
    ratio = 10 ** ((z[:, inner] - predicted) / 10)
    assert abs(10 * np.log10(np.nanmean(ratio))) < 0.5
    assert np.isfinite(ratio).all()
    assert not np.isfinite(z[:, r >= R_A]).any()


def test_folding_off_keeps_every_echo_first_trip():
    sweep = run({"weather.range_folding": False})
    r = sweep["range"].values
    z = sweep["DBZH"].values
    assert not np.isfinite(z[:, (r > 45e3) & (r < 55e3)]).any()
    assert np.isfinite(z[:, (r > 195e3) & (r < 205e3)]).all()


def test_overlaid_gates_are_flagged_and_scored_apart():
    sweep = run({"scene.reflectivity_dbz": 20.0})
    r = sweep["range"].values
    # Truth along range (the same on every radial): 20 dBZ, 40 dBZ in the storm.
    rt = 2000.0 + 250.0 * np.arange(1000)
    zt = np.where((rt >= 190e3) & (rt <= 210e3), 40.0, 20.0)
    own = 10 ** (zt / 10) / rt**2
    other = np.zeros_like(r)
    for k in (1, 2):
        far = r + k * R_A
        inside = far <= rt[-1]
        other[inside] += np.interp(far[inside], rt, own)
    with np.errstate(divide="ignore"):
        ratio_db = 10 * np.log10(other / np.interp(r, rt, own))
    flagged = sweep["overlaid"].values.astype(bool)
    visible = (r < R_A) & (r > 1e3)
    clear = visible & (np.abs(ratio_db + 20.0) > 0.5)  # away from the -20 dB threshold
    clear &= np.abs(r - (rt[-1] - R_A)) > 1e3  # and from the truth's end, folded
    clear &= (np.abs(r + R_A - 190e3) > 1e3) & (np.abs(r + R_A - 210e3) > 1e3)
    np.testing.assert_array_equal(
        flagged[:, clear], np.broadcast_to(ratio_db[clear] > -20.0, flagged[:, clear].shape)
    )
    assert not (flagged & sweep["scored"].values.astype(bool)).any()
    assert np.isnan(sweep["error_DBZH"].values[flagged]).all()
    scores = summarize(sweep)
    assert scores["DBZH"]["excluded"] == int(flagged.sum()) > 0
