"""A phase-coded scan's first-trip echo gives the uncoded moments (scan.ppi ``phase_code``).

Every echo carries the transmit phase of the pulse that made it; a processor that is not
SZ-2 coheres the dwell to the first trip (multiplies each pulse by e^(-j psi_m)) before it
estimates, so on a single-trip echo the moments cannot depend on the code.

What each test compares against: the same graph, scene and seed run uncoded. The weather
channel draws the same echo either way and multiplies it by the code; only the receiver
noise, added after, is turned by the cohering (its statistics unchanged). So the coded
run's error of every moment must have the uncoded run's mean within 5 standard errors of
the uncoded spread (sigma / sqrt(n)) and its standard deviation within 10 %. Without the
cohering the pulse-pair velocity is biased by metres per second and its width by more than
1 m/s (docs/reliability.md). The uniform scenes end (100 gates, 25 km) well inside the
unambiguous range (150 km at PRT 1 ms): one trip.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import xarray as xr

from pasim_graph.executor import BlockError, LocalExecutor, RunOptions
from pasim_graph.graph import load

from ..conftest import GRAPHS

SEED = 4
FIELDS = ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH")

#: processor -> (graph, overrides): 4 beams x 100 gates of a uniform scene at SNR 20-30 dB.
CHAINS: dict[str, tuple[str, dict[str, object]]] = {
    "pulse_pair": ("uniform_ideal.yaml", {}),
    "pulse_pair_ahv": ("uniform_ideal.yaml", {"weather.transmission": "ahv"}),
    "staggered": ("uniform_staggered.yaml", {}),
    "spectral_gmap": ("uniform_clutter.yaml", {}),
}


@functools.cache
def run(chain: str, code: str) -> xr.Dataset:
    graph, overrides = CHAINS[chain]
    given = {**overrides, "scan.azimuth_stop_deg": 4.0, "scan.phase_code": code}
    return LocalExecutor(load(GRAPHS / graph, given), RunOptions(seed=SEED)).run()


@pytest.mark.parametrize(
    "chain, code",
    [
        ("pulse_pair", "sz8_64"),
        ("pulse_pair", "random"),
        ("pulse_pair_ahv", "sz8_64"),
        ("staggered", "sz8_64"),
        ("spectral_gmap", "sz8_64"),
    ],
)
def test_coded_first_trip_moments_match_the_uncoded_run(chain: str, code: str) -> None:
    coded, plain = run(chain, code), run(chain, "none")
    assert "transmit_phase" in coded and "transmit_phase" not in plain
    for name in FIELDS:
        a, b = coded[f"error_{name}"].values.ravel(), plain[f"error_{name}"].values.ravel()
        a, b = a[np.isfinite(a)], b[np.isfinite(b)]
        assert a.size > 300 and abs(a.size - b.size) <= 0.02 * b.size, name
        se = b.std() / np.sqrt(b.size)
        assert abs(a.mean() - b.mean()) < 5 * se, (name, a.mean(), b.mean(), se)
        assert abs(a.std() / b.std() - 1) < 0.10, (name, a.std(), b.std())


def test_the_expected_level_refuses_a_phase_code_by_name() -> None:
    """The weather channel's ``expected`` level has no pulses to carry a code: refused, one
    line naming scan.ppi's phase_code (not the range-folding advice, which would not help)."""
    overrides = {
        "scan.azimuth_stop_deg": 2.0,
        "scan.phase_code": "sz8_64",
        "weather.method": "expected",
    }
    graph = load(GRAPHS / "uniform_ideal.yaml", overrides)
    with pytest.raises(BlockError, match="phase_code") as err:
        LocalExecutor(graph, RunOptions()).run()
    assert "\n" not in str(err.value) and "range_folding" not in str(err.value)
