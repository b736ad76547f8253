"""The NEXRAD split cut (scan.doppler_cut, processor.split_cut) and its range unfolding.

What each test compares against:

* the unfolding rule on hand-made surveillance reflectivity: the Doppler gate's echo goes to
  the candidate range whose surveillance power Z / r^2 exceeds the others' sum by the
  threshold (5 dB), and nowhere when none does (the legacy TOVER rule, Doviak and Zrnic
  1993 section 7.4.2), computed here by hand;
* the chain (split_cut_storm.yaml: a 20 dBZ field with a 40 dBZ storm at 190-210 km): the
  Doppler cut's velocity of the storm, folded to 40-60 km by its 1 ms PRT, is put back at
  190-210 km where the surveillance cut (PRT 3.33 ms, unambiguous to 500 km) sees the storm;
  the gates under it, whose own echo is 8 dB weaker than the folded storm's by the radar
  equation, get no velocity; reflectivity is the surveillance cut's; the Nyquist velocity is
  the Doppler cut's.
"""

from __future__ import annotations

import numpy as np
from pasim_blocks.processing.split_cut import unfold

from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graph import load

from ..conftest import GRAPHS


def test_unfold_rule_by_hand():
    rng = 1000.0 + 1000.0 * np.arange(30)  # gates every km from 1 km
    r_a = 10_000.0  # ten gates per trip
    dbz = np.full((1, 30), np.nan)
    dbz[0, 2] = 20.0  # gate 2 (3 km) alone: assigned to itself
    dbz[0, 5], dbz[0, 15] = 20.0, 40.0  # 6 km vs 16 km: 40 - 20 - 20 log10(16 / 6) = 11.5 dB
    dbz[0, 7], dbz[0, 17] = 30.0, 38.0  # 8 km vs 18 km: 38 - 30 - 20 log10(18 / 8) = 0.96 dB
    near, target = unfold(dbz, rng, r_a, 5.0)
    assert list(near) == list(range(9))  # 1 to 9 km
    t = target[0]
    assert t[2] == 2
    assert t[5] == 15
    assert t[7] == -1  # too close to call: range-folded
    assert t[0] == -1  # no echo anywhere


def test_split_cut_unfolds_the_folded_storm():
    graph = load(GRAPHS / "split_cut_storm.yaml")
    sweep = LocalExecutor(graph, RunOptions(seed=6)).run()
    r = sweep["range"].values
    v = sweep["VRADH"].values
    storm = (r > 192e3) & (r < 208e3)
    under = (r > 192e3 - 149_896.2) & (r < 208e3 - 149_896.2)
    assert np.isfinite(v[:, storm]).mean() > 0.95
    assert abs(np.nanmean(v[:, storm]) - 5.0) < 0.3
    assert not np.isfinite(v[:, under]).any()
    assert abs(np.nanmean(sweep["DBZH"].values[:, storm]) - 40.0) < 1.0
    assert float(sweep["nyquist_velocity"].values[0]) == np.float64(299_792_458.0 / 2.8e9 / 4e-3)
    elsewhere = (r > 70e3) & (r < 140e3)  # 20 dBZ, unfolded to itself
    assert np.isfinite(v[:, elsewhere]).mean() > 0.95
