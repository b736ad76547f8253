"""The study's noise and scene intervals and its paired comparisons (blocks/study/intervals.py),
on synthetic per-beam errors whose answer is known by an independent computation: many noise
draws of one scene (the noise interval's coverage of their mean), a direct resampling of the
gates (the scene interval) and many independent scenes (the paired interval's narrowing).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from pasim_blocks.study.intervals import (
    noise_interval,
    paired,
    picks,
    scene_interval,
)

from ..conftest import tiny_study_file

BEAMS, GATES = 90, 120


def scene(rng: np.random.Generator) -> np.ndarray:
    """A weather term (beam, range): its spread changes from beam to beam (slowly, as a storm
    does along azimuth), gates correlated along range."""
    scale = np.exp(np.convolve(rng.normal(0, 0.5, BEAMS + 8), np.ones(9) / 3, "valid"))
    z = rng.normal(0, 1, (BEAMS, GATES + 4))
    z = (z[:, :-4] + z[:, 1:-3] + z[:, 2:-2] + z[:, 3:-1] + z[:, 4:]) / np.sqrt(5)
    return 1.5 * scale[:, None] * z


def noise(rng: np.random.Generator) -> np.ndarray:
    """A noise draw (beam, range): independent beams, gates correlated along range (a range
    response of three gates), its level rising along range (SNR falling)."""
    level = np.linspace(0.6, 1.4, GATES)
    z = rng.normal(0, 1, (BEAMS, GATES + 2))
    z = (z[:, :-2] + z[:, 1:-1] + z[:, 2:]) / np.sqrt(3)
    return level * z


def test_the_one_seed_noise_interval_covers_the_mean_over_noise_draws_at_95_percent():
    # Independent answer: 400 noise draws on one fixed scene; the mean of their std is what
    # every one-seed noise interval should cover 95 % of the time, and its width should be
    # that of the draws' own scatter (+-1.96 sd), not the scene's (several times wider).
    rng = np.random.default_rng(1)
    s = scene(rng)
    draws = [noise(rng) for _ in range(400)]
    stds = np.array([(s + n).std(ddof=1) for n in draws])
    biases = np.array([(s + n).mean() for n in draws])
    cover_s = cover_b = 0
    widths = []
    for n in draws:
        (slo, shi), (blo, bhi) = noise_interval([s + n], [n])
        cover_s += slo <= stds.mean() <= shi
        cover_b += blo <= biases.mean() <= bhi
        widths.append(shi - slo)
    assert 0.90 <= cover_s / len(draws) <= 0.99
    assert 0.90 <= cover_b / len(draws) <= 0.99
    assert np.mean(widths) == pytest.approx(2 * 1.96 * stds.std(ddof=1), rel=0.2)
    # The scene interval of the same draw is far wider: it is another quantity.
    scene_w = np.diff(scene_interval([s + draws[0]], 3)[0])[0]
    assert scene_w > 3 * np.mean(widths)


def test_the_several_seed_noise_interval_covers_the_mean_at_95_percent():
    # Student's t on three seeds: coverage of the mean over all draws, 300 triples.
    rng = np.random.default_rng(2)
    s = scene(rng)
    draws = [noise(rng) for _ in range(900)]
    truth = np.mean([(s + n).std(ddof=1) for n in draws])
    hits = 0
    for k in range(0, 900, 3):
        (lo, hi), _ = noise_interval([s + n for n in draws[k : k + 3]], None)
        hits += lo <= truth <= hi
    assert 0.90 <= hits / 300 <= 0.99


def test_the_scene_interval_is_a_direct_resampling_of_whole_blocks():
    # Independent computation: the resampled blocks' gates gathered explicitly and their std
    # and mean taken by numpy, per seed, averaged over the seeds, 2.5 and 97.5 percentiles.
    rng = np.random.default_rng(3)
    s = scene(rng)
    seeds = [s + noise(rng) for _ in range(2)]
    seeds[1][5, 7] = np.nan  # an unscored gate
    block = 4
    blocks = [np.arange(i, min(i + block, BEAMS)) for i in range(0, BEAMS, block)]
    pick = picks(len(blocks), 0)
    stds, means = [], []
    for row in pick:
        st, mn = [], []
        for d in seeds:
            x = np.concatenate([d[blocks[j]].ravel() for j in row])
            x = x[np.isfinite(x)]
            st.append(x.std(ddof=1))
            mn.append(x.mean())
        stds.append(np.mean(st))
        means.append(np.mean(mn))
    want_s = np.percentile(stds, [2.5, 97.5])
    want_b = np.percentile(means, [2.5, 97.5])
    got_s, got_b = scene_interval(seeds, block)
    np.testing.assert_allclose(got_s, want_s, rtol=1e-9)
    np.testing.assert_allclose(got_b, want_b, rtol=1e-9)


def test_the_scene_interval_keeps_its_meaning_whatever_the_seeds():
    # The issue: with several seeds the old interval became the (much narrower) spread across
    # draws. The scene interval of one seed and of eight seeds of the same weather must be of
    # the same width, and the noise interval of eight seeds far narrower than either.
    rng = np.random.default_rng(4)
    s = scene(rng)
    seeds = [s + noise(rng) for _ in range(8)]
    one = np.diff(scene_interval(seeds[:1], 3)[0])[0]
    eight = np.diff(scene_interval(seeds, 3)[0])[0]
    assert eight == pytest.approx(one, rel=0.25)
    noise8 = np.diff(noise_interval(seeds, None)[0])[0]
    assert noise8 < eight / 3


def test_the_paired_interval_is_narrower_than_the_unpaired_by_the_expected_factor():
    # Two systems that see the same weather term (a beam-smoothed version differing by a
    # factor) with their own independent errors. Expected factor, independently: the sd of
    # std(a) - std(b) over 300 independent scenes where both share each scene, over its sd
    # where b sees another scene (the unpaired comparison).
    rng = np.random.default_rng(5)

    def pair(w: np.ndarray, r: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        return w + 0.4 * noise(r), 1.15 * w + 0.6 * noise(r)

    same, other = [], []
    for _ in range(300):
        a, b = pair(scene(rng), rng)
        _, b2 = pair(scene(rng), rng)
        same.append(a.std(ddof=1) - b.std(ddof=1))
        other.append(a.std(ddof=1) - b2.std(ddof=1))
    expected = np.std(same, ddof=1) / np.std(other, ddof=1)
    assert expected < 0.5  # the model does share a weather term
    ratios = []
    for k in range(20):
        r = np.random.default_rng(100 + k)
        a, b = pair(scene(r), r)
        got = paired([a], [b], 3, [0.4 * noise(r)], [0.6 * noise(r)])
        ratios.append(got["paired_over_unpaired"])
        lo, hi = got["scene_ci"]
        assert lo <= got["difference"] <= hi
    # A block bootstrap's width of one scene scatters; its mean over 20 scenes is the factor.
    assert np.mean(ratios) == pytest.approx(expected, rel=0.3)


def test_a_real_difference_ranks_with_one_seed_and_no_difference_does_not():
    # System b's own errors are 30 % larger on the same weather: ranked with one seed. Two
    # systems alike but for their noise draws: unranked in at least 90 % of 40 trials (both
    # intervals of the difference must exclude zero, each 95 %).
    rng = np.random.default_rng(6)
    w = scene(rng)
    na, nb = noise(rng), 1.3 * noise(rng)
    got = paired([w + na], [w + nb], 3, [na], [nb])
    assert got["ranked"] and got["separated_by"] == ["noise", "scene"]
    assert got["difference"] < 0
    ranked = 0
    for k in range(40):
        r = np.random.default_rng(200 + k)
        w = scene(r)
        na, nb = noise(r), noise(r)
        ranked += paired([w + na], [w + nb], 3, [na], [nb])["ranked"]
    assert ranked <= 4


# A tiny real study: the two pencil beams of tests/fixtures/study on 8 beams, 8 pulses, run
# with one seed and with three. Its sector is short (2 to 3 bootstrap blocks), so its scene
# intervals are crude; the test asks only that the rankings do not contradict each other.


def scores(out: Path) -> dict:
    return {**json.loads((out / "scores.json").read_text()), "_out": out}


@pytest.fixture(scope="module")
def one_and_three(tmp_path_factory, tiny_study) -> tuple[dict, dict]:
    # The one-seed study is the tiny study itself (shared with the other study tests); the
    # three-seed one is a copy of it with seeds 1 and 2 added (runner.added_seeds): its seed-0
    # runs are kept, not run again (test_study_seeds_added.py checks that this is the study
    # begun with three seeds, value for value).
    from pasim_graph.cli import main

    tmp = tmp_path_factory.mktemp("three")
    shutil.copytree(tiny_study, tmp / "out")
    study = tiny_study_file(tmp, "[0, 1, 2]")
    assert main(["study", str(study), "--out", str(tmp / "out"), "--resume", "--no-report"]) == 0
    return scores(tiny_study), scores(tmp / "out")


def test_rankings_agree_between_one_and_three_seeds(one_and_three):
    # A pair ranked (its paired difference outside both intervals) with one seed must not be
    # ranked the other way with three, and the reverse; the 1 deg beam's DBZH beats the
    # 2 deg beam's with either (the main-lobe smoothing doubles), so the check is not empty.
    one, three = (s["_study"]["pairs"]["convective"] for s in one_and_three)
    assert one.keys() == three.keys() and "DBZH" in one
    ranked_both = 0
    for field in one:
        (p1,), (p3,) = one[field], three[field]
        sign1 = np.sign(p1["difference"]) if p1["a"] == "narrow" else -np.sign(p1["difference"])
        sign3 = np.sign(p3["difference"]) if p3["a"] == "narrow" else -np.sign(p3["difference"])
        if p1["ranked"] or p3["ranked"]:
            assert sign1 == sign3, field
        ranked_both += p1["ranked"] and p3["ranked"]
        assert (
            p1["difference"]
            == pytest.approx(
                one_and_three[0]["narrow"]["convective"]["-"][field]["common"]["std"]
                - one_and_three[0]["wide"]["convective"]["-"][field]["common"]["std"]
            )
            or p1["a"] == "wide"
        )
    assert one["DBZH"][0]["ranked"] and three["DBZH"][0]["ranked"]
    assert ranked_both >= 1
    for s in one_and_three:
        assert s["_study"]["rankings"]["convective"]["DBZH"] == [["narrow"], ["wide"]]


def test_the_three_seed_noise_interval_is_students_t_of_the_seeds(one_and_three):
    # Independent: each seed's DBZH std read from its store with xarray, a t interval with 2
    # degrees of freedom (scipy's t quantile) around their mean.
    import xarray as xr
    from scipy import stats

    _, three = one_and_three
    got = three["narrow"]["convective"]["-"]["DBZH"]
    stds = []
    for seed in range(3):
        path = three["_out"] / "runs/narrow/convective/-" / f"estimate-seed{seed}.zarr"
        ds = xr.open_datatree(path, engine="zarr")["sweep_0"].to_dataset()
        x = np.asarray(ds["error_DBZH"].values, dtype=float)
        stds.append(x[np.isfinite(x)].std(ddof=1))
    half = stats.t.ppf(0.975, 2) * np.std(stds, ddof=1) / np.sqrt(3)
    np.testing.assert_allclose(got["noise_ci"]["std"], [np.mean(stds) - half, np.mean(stds) + half])
    assert "Student's t across 3 seeds" in got["noise_ci"]["method"]
    assert "block bootstrap" in got["scene_ci"]["method"]
    assert got["std_ci"] == got["scene_ci"]["std"]  # the compatibility key is the scene one
    one, _ = one_and_three
    n1 = one["narrow"]["convective"]["-"]["DBZH"]
    assert "delta-method" in n1["noise_ci"]["method"]
    assert n1["noise_ci"]["std"][0] < n1["std"] < n1["noise_ci"]["std"][1]
