"""The study's two kinds of 95 % interval, and the paired comparison of two systems.

- The NOISE interval: what another noise draw of the same weather would give. Several seeds:
  Student's t on the per-seed values. One seed: the statistic's variance under the noise
  alone, the scene held fixed (delta method): a gate's error is ``d = s + n``, ``n`` the
  estimate minus the system's own expected (noise-free) level and ``s = d - n`` fixed by the
  weather; the statistic's change from the noise is a sum of per-beam contributions (each
  beam is its own draw of pulses and receiver noise, so beams are independent under the
  noise), whose variances are estimated from successive differences between neighbouring
  beams (``var(c_b) ~ (c_b - c_b+1)^2 / 2``: the mean level changes slowly along azimuth,
  the draws do not correlate).
- The SCENE interval: what another stretch of the same kind of weather would give: a block
  bootstrap over whole beams (blocks of about three beamwidths, the same blocks for every
  seed, the statistic averaged over the seeds of each resample).

``paired`` compares two systems seen on the same weather, seeds and gates through the per-beam
difference of their statistics: the weather term they share cancels, so the difference's
intervals are narrower than the two systems' own intervals combined.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

BOOTSTRAP = 1000
Z95 = 1.959963984540054


def t_interval(values: list[float]) -> list[float]:
    from scipy import stats

    v = np.asarray(values, dtype=float)
    half = stats.t.ppf(0.975, v.size - 1) * v.std(ddof=1) / math.sqrt(v.size)
    return [float(v.mean() - half), float(v.mean() + half)]


def block_sums(d: np.ndarray, block: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Count, sum and sum of squares of the finite values of ``d`` (beam, range) per block of
    ``block`` beams."""
    ok = np.isfinite(d)
    x = np.where(ok, d, 0.0)
    n, s1, s2 = ok.sum(1).astype(float), x.sum(1), (x * x).sum(1)
    starts = np.arange(0, d.shape[0], max(1, block))
    return (np.add.reduceat(n, starts), np.add.reduceat(s1, starts), np.add.reduceat(s2, starts))


def _std_bias(N: np.ndarray, S1: np.ndarray, S2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    with np.errstate(invalid="ignore", divide="ignore"):
        bias = S1 / N
        var = np.maximum(S2 - S1**2 / N, 0.0) / (N - 1)
    bad = N < 2
    return np.where(bad, np.nan, np.sqrt(var)), np.where(bad, np.nan, bias)


def picks(nblocks: int, seed: int = 0) -> np.ndarray:
    """The resampled blocks (BOOTSTRAP, nblocks), the same for every series compared."""
    return np.random.default_rng(seed).integers(0, nblocks, size=(BOOTSTRAP, nblocks))


def resampled(per_seed: list[np.ndarray], block: int, pick: np.ndarray) -> tuple[Any, Any]:
    """Std and bias of each resample of ``pick``, averaged over the seeds (BOOTSTRAP,)."""
    stds, biases = [], []
    for d in per_seed:
        n, s1, s2 = block_sums(d, block)
        s, b = _std_bias(n[pick].sum(1), s1[pick].sum(1), s2[pick].sum(1))
        stds.append(s)
        biases.append(b)
    return np.mean(stds, axis=0), np.mean(biases, axis=0)


def _pct(x: np.ndarray) -> list[float]:
    x = x[np.isfinite(x)]
    if x.size < 2:
        return [math.nan, math.nan]
    return [float(v) for v in np.percentile(x, [2.5, 97.5])]


def scene_interval(
    per_seed: list[np.ndarray], block: int, seed: int = 0
) -> tuple[list[float], list[float]]:
    """Scene intervals of (std, bias): block bootstrap over beams, the same blocks for every
    seed, the seeds' statistics averaged in each resample."""
    n = block_sums(per_seed[0], block)[0]
    if n.size < 2 or n.sum() < 3:
        return [math.nan, math.nan], [math.nan, math.nan]
    std, bias = resampled(per_seed, block, picks(n.size, seed))
    return _pct(std), _pct(bias)


def noise_contributions(d: np.ndarray, noise: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each beam's part in how the noise moves the std and the bias of ``d`` (beam, range) on
    its finite gates: ``noise`` is the noise term of ``d`` (estimate minus own expected
    level), ``d - noise`` the scene's fixed part. Returns per-beam contributions (std, bias)
    whose sums over beams are the statistics' noise-driven changes (to first order)."""
    ok = np.isfinite(d) & np.isfinite(noise)
    N = int(ok.sum())
    if N < 3:
        return np.full(d.shape[0], np.nan), np.full(d.shape[0], np.nan)
    e = np.where(ok, d, 0.0)
    s = np.where(ok, d - noise, 0.0)
    ebar, sbar = e.sum() / N, s.sum() / N
    g = np.where(ok, (e - ebar) ** 2 - (s - sbar) ** 2, 0.0)
    # Less each gate's mean share: beams scoring more gates do not differ in mean for it.
    de = (g.sum(1) - ok.sum(1) * g.sum() / N) / (N - 1)
    std = math.sqrt(max(float(np.where(ok, (e - ebar) ** 2, 0.0).sum() / (N - 1)), 1e-300))
    nb = np.where(ok, noise, 0.0)
    return de / (2 * std), (nb.sum(1) - ok.sum(1) * nb.sum() / N) / N


def successive_variance(c: np.ndarray) -> float:
    """Sum over beams of each beam's variance, from successive differences of independent
    per-beam contributions ``c`` whose mean varies slowly along azimuth."""
    c = c[np.isfinite(c)]
    if c.size < 2:
        return math.nan
    return float(c.size * np.mean(np.diff(c) ** 2) / 2)


def noise_interval(
    per_seed: list[np.ndarray], noise: list[np.ndarray] | None
) -> tuple[list[float], list[float]]:
    """Noise intervals of (std, bias) of per-seed errors (beam, range): Student's t across
    seeds, or with one seed the delta-method variance under the noise (``noise``: the seed's
    estimate minus own expected level on the same gates; None: unknown)."""
    if len(per_seed) > 1:
        stds, biases = [], []
        for d in per_seed:
            x = d[np.isfinite(d)]
            stds.append(float(x.std(ddof=1)) if x.size > 1 else math.nan)
            biases.append(float(x.mean()) if x.size else math.nan)
        return t_interval(stds), t_interval(biases)
    d = per_seed[0]
    x = d[np.isfinite(d)]
    if noise is None or x.size < 3:
        return [math.nan, math.nan], [math.nan, math.nan]
    cs, cb = noise_contributions(d, noise[0])
    std, bias = float(x.std(ddof=1)), float(x.mean())
    hs = Z95 * math.sqrt(successive_variance(cs))
    hb = Z95 * math.sqrt(successive_variance(cb))
    return [std - hs, std + hs], [bias - hb, bias + hb]


def _ci_excludes_zero(ci: list[float]) -> bool:
    return all(math.isfinite(v) for v in ci) and (ci[0] > 0 or ci[1] < 0)


def paired(
    a: list[np.ndarray],
    b: list[np.ndarray],
    block: int,
    noise_a: list[np.ndarray] | None = None,
    noise_b: list[np.ndarray] | None = None,
    seed: int = 0,
) -> dict[str, Any]:
    """The std of system ``a`` minus that of ``b``, per seed (beam, range) on the same gates:
    its noise interval (Student's t on the per-seed differences, or with one seed the
    delta-method variance of the per-beam difference of both systems' noise contributions),
    its paired scene interval (the same resampled blocks for both), the unpaired scene
    interval (independent resamples of each) and their widths' ratio."""
    std_a = [float(np.nanstd(x, ddof=1)) for x in a]
    std_b = [float(np.nanstd(x, ddof=1)) for x in b]
    diff = float(np.mean(std_a) - np.mean(std_b))
    if len(a) > 1:
        noise_ci = t_interval([x - y for x, y in zip(std_a, std_b, strict=True)])
    elif noise_a is not None and noise_b is not None:
        ca, _ = noise_contributions(a[0], noise_a[0])
        cb, _ = noise_contributions(b[0], noise_b[0])
        h = Z95 * math.sqrt(successive_variance(ca - cb))
        noise_ci = [diff - h, diff + h]
    else:
        noise_ci = [math.nan, math.nan]
    n = block_sums(a[0], block)[0]
    nan2 = [math.nan, math.nan]
    if n.size < 2:
        scene_ci = unpaired_ci = nan2
    else:
        p = picks(n.size, seed)
        sa, _ = resampled(a, block, p)
        sb, _ = resampled(b, block, p)
        scene_ci = _pct(sa - sb)
        # Unpaired: each system resampled on its own blocks (independent stretches of weather).
        sb_ind, _ = resampled(b, block, picks(n.size, seed + 1))
        unpaired_ci = _pct(sa - sb_ind)
    pw, uw = scene_ci[1] - scene_ci[0], unpaired_ci[1] - unpaired_ci[0]
    by_noise, by_scene = _ci_excludes_zero(noise_ci), _ci_excludes_zero(scene_ci)
    if by_noise and by_scene:
        verdict = "ranked: both intervals of the difference exclude zero"
    elif by_noise:
        verdict = "unranked: separated within this weather's noise only, not across the scene"
    elif by_scene:
        verdict = "unranked within noise (the scene interval alone excludes zero)"
    else:
        verdict = "unranked within noise"
    return {
        "difference": diff,
        "noise_ci": noise_ci,
        "scene_ci": scene_ci,
        "unpaired_scene_ci": unpaired_ci,
        "paired_over_unpaired": pw / uw if uw > 0 else math.nan,
        "ranked": by_noise and by_scene,
        "separated_by": [k for k, v in (("noise", by_noise), ("scene", by_scene)) if v],
        "verdict": verdict,
    }
