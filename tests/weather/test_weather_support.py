"""The scene-aware support (``channel.weather`` parameter ``support_fraction``): which cells
are left undrawn, checked against a brute-force selection written independently here."""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.weather.beams import significant_cells


def brute_force(power: np.ndarray, gate: np.ndarray, fraction: float) -> np.ndarray:
    """Gate by gate: drop cells weakest first while the dropped sum stays <= fraction x total."""
    keep = np.ones(power.size, bool)
    for g in np.unique(gate):
        idx = np.flatnonzero(gate == g)
        total = power[idx].sum()
        dropped = 0.0
        for i in idx[np.argsort(power[idx], kind="stable")]:
            if dropped + power[i] > fraction * total:
                break
            dropped += power[i]
            keep[i] = False
    return keep


@pytest.mark.parametrize("fraction", [1e-4, 1e-3, 1e-2, 0.1])
def test_selection_equals_a_brute_force_one(fraction: float) -> None:
    rng = np.random.default_rng(7)
    gate = np.sort(rng.integers(0, 40, 3000))
    # Powers over 12 decades, as sidelobes against a main lobe give them.
    power = 10 ** rng.uniform(-12, 0, gate.size)
    keep = significant_cells(power, gate, fraction)
    np.testing.assert_array_equal(keep, brute_force(power, gate, fraction))
    for g in np.unique(gate):
        at = gate == g
        assert power[at & ~keep].sum() <= fraction * power[at].sum() * (1 + 1e-12)
        assert keep[at].any()  # the strongest cell of a gate is always drawn


def test_zero_fraction_draws_every_cell() -> None:
    gate = np.array([0, 0, 1, 2, 2])
    power = np.array([1e-30, 1.0, 0.0, 1e-9, 1.0])
    assert significant_cells(power, gate, 0.0).all()


def _scores(capsys, tmp_path, seed: int, fraction: float) -> dict:
    import json

    from ..conftest import GRAPHS, pasim_out

    out = tmp_path / f"s{seed}-{fraction:g}.zarr"
    code, _, err = pasim_out(
        capsys, "run", str(GRAPHS / "atd_radar.yaml"), "--sector", "280:286",
        "--seed", str(seed), "--set", f"weather.support_fraction={fraction:g}",
        "--out", str(out),
    )  # fmt: skip
    assert code == 0, err
    code, text, err = pasim_out(capsys, "score", str(out), "--json")
    assert code == 0, err
    return json.loads(text)


def test_the_array_with_a_scene_support_scores_as_with_every_cell(capsys, tmp_path) -> None:
    """The ATD (whose pattern keeps every radial of the sector above the -100 dB support) at
    the covariance level, two seeds: leaving undrawn 0.1 % of each gate's echo changes which
    random numbers go where, not the distribution. Bias and std of every moment stay within
    the spread of the two seeds' own scores (plus a floor of 2 % of the std), and the DBZH
    bias moves by no more than the 0.0043 dB (10 log10(1 - 1e-3)) the power left out allows,
    beyond that same noise."""
    full = [_scores(capsys, tmp_path, s, 0.0) for s in (1, 2)]
    part = [_scores(capsys, tmp_path, s, 1e-3) for s in (1, 2)]
    for moment in ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"):
        for q in ("bias", "std"):
            seeds = [f[moment][q] for f in full]
            spread = abs(seeds[0] - seeds[1]) + 0.02 * full[0][moment]["std"]
            for f, p in zip(full, part, strict=True):
                assert abs(p[moment][q] - f[moment][q]) <= 2 * spread, (moment, q, f, p)
        assert full[0][moment]["count"] == part[0][moment]["count"]
