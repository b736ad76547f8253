"""A study's statistics: three references, own and common gates, intervals, error budget.

Every statistic is of a gate's error (estimate minus reference), velocity and phi_DP on their
circles (the scorer's ``period``): against the raw NEXRAD gates (the scorer's ``error_*``),
against the reference system's ``expected`` level and against the system's own. Every
statistic has two 95 % intervals (:mod:`.intervals`): the noise interval (another noise draw
of the same weather: Student's t across seeds, or the delta-method variance under the noise
with one seed) and the scene interval (another stretch of weather: a block bootstrap over
whole beams in blocks of about three beamwidths; neighbouring gates and beams are correlated,
so a naive standard error would be far too small). Rankings compare systems in pairs, through
the per-beam difference of their statistics on the gates both scored.

A system whose graph carries algorithm blocks (``algorithm.*``, docs/algorithms.md) stores
each product's error against the same algorithm's answer from the truth (``error_KDP_VULPIANI``
...): those products get the same statistics and intervals as the moments, against the raw
truth (the ideal answer), the reference's and the own expected level, on own and common gates,
listed after the moments; rankings and pairs stay the moments'.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pasim_graph.fm301 import MOMENT_FIELDS
from pasim_graph.serialize import json_safe

from .intervals import (
    BOOTSTRAP,
    block_sums,
    noise_interval,
    paired,
    scene_interval,
)
from .model import Study
from .plan import CALIBRATION, Run

FIELDS = MOMENT_FIELDS
BLOCK_BEAMWIDTHS = 3.0
#: The quadrature sum of the parts must match the total within this fraction.
BUDGET_TOLERANCE = 0.10
MAD_TO_STD = 1.4826  # the MAD of a Gaussian times this is its standard deviation


@dataclass
class Errors:
    """The scorer's errors of one store, on its grid."""

    azimuth: np.ndarray
    range: np.ndarray
    fields: dict[str, np.ndarray]  # (beam, range) float64, NaN where unscored
    periods: dict[str, float]
    requirements: dict[str, tuple[float, float]]
    units: dict[str, str]
    #: The algorithm products among ``fields`` (stored errors that are not moments), in
    #: the store's order.
    products: list[str] = dataclasses.field(default_factory=list)

    def same_grid(self, other: Errors) -> bool:
        return (
            self.azimuth.shape == other.azimuth.shape
            and self.range.shape == other.range.shape
            and bool(np.allclose(self.azimuth, other.azimuth, atol=1e-3))
            and bool(np.allclose(self.range, other.range, atol=1e-3))
        )


def root_token(path: Path) -> tuple[int, int]:
    """What changes whenever a store is completed or rewritten: its root metadata's
    modification time and size (the completion marker and the task record live there)."""
    st = (path / "zarr.json").stat()
    return st.st_mtime_ns, st.st_size


def read_errors(path: str | Path) -> Errors:
    from pasim_graph.store import open_sweep

    sweep, _ = open_sweep(path)
    dim = "azimuth" if "azimuth" in sweep.dims else next(iter(sweep.dims))
    fields, periods, reqs, units = {}, {}, {}, {}
    for name in FIELDS:
        var = sweep.get(f"error_{name}")
        if var is None:
            continue
        fields[name] = np.asarray(var.values, dtype=np.float64)
        if "period" in var.attrs:
            periods[name] = float(var.attrs["period"])
        reqs[name] = (float(var.attrs["requirement_bias"]), float(var.attrs["requirement_std"]))
        units[name] = str(var.attrs.get("units", ""))
    products = []
    for key, var in sweep.data_vars.items():
        name = str(key).removeprefix("error_")
        if name == key or name in FIELDS or var.attrs.get("pasim_role") != "error":
            continue
        fields[name] = np.asarray(var.values, dtype=np.float64)
        reqs[name] = (float(var.attrs["requirement_bias"]), float(var.attrs["requirement_std"]))
        units[name] = str(var.attrs.get("units", ""))
        products.append(name)
    return Errors(
        np.asarray(sweep[dim].values, dtype=np.float64),
        np.asarray(sweep["range"].values, dtype=np.float64),
        fields,
        periods,
        reqs,
        units,
        products,
    )


def scored_names(errors: Errors) -> tuple[str, ...]:
    """The moments, then the algorithm products, in the order a study scores them."""
    return (*FIELDS, *errors.products)


def wrap(d: np.ndarray, period: float | None) -> np.ndarray:
    """A difference on the circle of ``period`` into [-period/2, period/2)."""
    if not period:
        return d
    return (d + period / 2) % period - period / 2


def robust_std(x: np.ndarray) -> float:
    if x.size < 2:
        return float("nan")
    return float(MAD_TO_STD * np.median(np.abs(x - np.median(x))))


def bootstrap(d: np.ndarray, block: int, seed: int = 0) -> tuple[list[float], list[float]]:
    """95 % scene intervals of (std, bias) of the finite values of ``d`` (beam, range),
    resampling whole blocks of ``block`` beams with replacement."""
    return scene_interval([d], block, seed)


NOISE_ONE_SEED = (
    "noise: delta-method variance under the noise alone (estimate minus own expected level), "
    "the scene held fixed, from successive differences of per-beam contributions"
)


def statistics(
    per_seed: list[np.ndarray],
    block: int,
    requirement: tuple[float, float],
    noise: list[np.ndarray] | None = None,
) -> dict[str, Any]:
    """Std, robust spread, bias, count and their noise and scene intervals of per-seed errors
    (beam, range); ``noise``: each seed's noise term (estimate minus own expected level) on
    the same grid, for the one-seed noise interval."""
    rows = []
    for d in per_seed:
        x = d[np.isfinite(d)]
        rows.append(
            (
                float(x.std(ddof=1)) if x.size > 1 else math.nan,
                robust_std(x),
                float(x.mean()) if x.size else math.nan,
                int(x.size),
            )
        )
    std, rstd, bias = (float(np.mean([r[i] for r in rows])) for i in range(3))
    count = int(rows[0][3])
    noise_std, noise_bias = noise_interval(per_seed, noise)
    scene_std, scene_bias = scene_interval(per_seed, block)
    noise_how = (
        f"noise: Student's t across {len(per_seed)} seeds" if len(per_seed) > 1 else NOISE_ONE_SEED
    )
    scene_how = (
        f"scene: block bootstrap over beams, blocks of {block} beams, {BOOTSTRAP} resamples"
        + (f", the same blocks for the {len(per_seed)} seeds" if len(per_seed) > 1 else "")
    )
    req_b, req_s = requirement
    return {
        "std": std,
        "robust_std": rstd,
        "bias": bias,
        "count": count,
        "pass": bool(count > 1 and abs(bias) <= req_b and std <= req_s),
        "noise_ci": {"std": noise_std, "bias": noise_bias, "method": noise_how},
        "scene_ci": {"std": scene_std, "bias": scene_bias, "method": scene_how},
        # Compatibility (sweep trends, design figures, older readers): the scene interval.
        "std_ci": scene_std,
        "bias_ci": scene_bias,
        "interval": f"{noise_how}; {scene_how}; std_ci and bias_ci are the scene interval",
    }


def std_intervals(
    terms: dict[str, np.ndarray], ok: np.ndarray, block: int, seed: int = 0
) -> dict[str, list[float]]:
    """95 % intervals of the std of each term (beam, range) on the gates ``ok``, by one block
    bootstrap over beams shared by all terms (the same resampled beams for every part)."""
    sums = {k: block_sums(np.where(ok, d, np.nan), max(1, block)) for k, d in terms.items()}
    n = next(iter(sums.values()))[0]
    if n.size < 2 or n.sum() < 3:
        return {k: [math.nan, math.nan] for k in terms}
    pick = np.random.default_rng(seed).integers(0, n.size, size=(BOOTSTRAP, n.size))
    out = {}
    for k, (nk, s1, s2) in sums.items():
        N, S1, S2 = nk[pick].sum(1), s1[pick].sum(1), s2[pick].sum(1)
        good = N > 1
        var = np.maximum(S2[good] - S1[good] ** 2 / N[good], 0.0) / (N[good] - 1)
        out[k] = [float(v) for v in np.percentile(np.sqrt(var), [2.5, 97.5])]
    return out


def budget(
    est: np.ndarray,
    own: np.ndarray,
    free: np.ndarray,
    short: np.ndarray,
    period: float | None,
    block: int = 1,
) -> dict[str, Any]:
    """The error against the raw gates split along est - raw = (est - own expected) +
    (own - sidelobe-free) + (sidelobe-free - short pulse) + (short pulse - raw), on the gates
    where all four are defined. The parts are standard deviations; their quadrature sum
    equals the total only when the parts are uncorrelated, and the cross terms say how far."""
    parts_d = {
        "estimator_noise": wrap(est - own, period),
        "sidelobes": wrap(own - free, period),
        "range": wrap(free - short, period),
        "main_lobe": short,
    }
    ok = np.isfinite(est)
    for d in parts_d.values():
        ok &= np.isfinite(d)
    n = int(ok.sum())
    if n < 3:
        return {"count": n, "note": "fewer than 3 gates where every reference is defined"}
    total_d = est[ok]
    parts = {k: float(v[ok].std(ddof=1)) for k, v in parts_d.items()}
    total = float(total_d.std(ddof=1))
    quadrature = math.sqrt(sum(p * p for p in parts.values()))
    out: dict[str, Any] = {
        **parts,
        "bias": float(total_d.mean()),
        "total": total,
        "quadrature_sum": quadrature,
        "count": n,
        # Each part's share of the variance the parts add up to (the stacked bars' heights).
        "variance_share": {
            k: p * p / quadrature**2 if quadrature > 0 else math.nan for k, p in parts.items()
        },
        "ci": std_intervals({**parts_d, "total": est}, ok, block),
        "ci_method": (
            "scene: the bootstrap of the parts, one block bootstrap over beams (every seed's "
            "gates of a beam kept together) resampling all parts and the total together"
        ),
    }
    adds = total > 0 and abs(quadrature - total) <= BUDGET_TOLERANCE * total
    out["adds_up"] = bool(adds)
    if not adds and total > 0:
        # The cross terms: 2 cov(a, b) of the parts, the largest named.
        keys = list(parts_d)
        crosses = {
            f"{a}x{b}": 2 * float(np.cov(parts_d[a][ok], parts_d[b][ok])[0, 1])
            for i, a in enumerate(keys)
            for b in keys[i + 1 :]
        }
        worst = max(crosses, key=lambda k: abs(crosses[k]))
        share = (total**2 - quadrature**2) / total**2
        out["note"] = (
            f"the parts are correlated: cross terms make {share:+.0%} of the total variance, "
            f"the largest {worst.replace('x', ' with ')} ({crosses[worst]:+.3g})"
        )
    return out


def _block_beams(azimuth: np.ndarray, beamwidth: float | None) -> int:
    spacing = float(np.median(np.abs(np.diff(azimuth)))) if azimuth.size > 1 else 1.0
    bw = beamwidth or spacing
    return max(2, round(BLOCK_BEAMWIDTHS * bw / max(spacing, 1e-6)))


def score_study(
    study: Study,
    runs: list[Run],
    out: Path,
    beamwidths: dict[str, float],
    patterns: dict[str, Any] | None = None,
    read: dict[str, tuple[tuple[int, int], Errors]] | None = None,
) -> dict[str, Any]:
    """Scores of every system, case and point whose runs are all finished; ``patterns``: the
    antenna figures the runner measured (:mod:`.patterns`), by ``SYSTEM/CASE/POINT``;
    ``read``: the errors of the stores read by an earlier call, kept by the caller.

    A study scores again after every run it finishes; without ``read`` each call would read
    (and verify the checksums of) every finished store again, so a study of N runs read
    N^2 / 2 stores. A store is read again only if its root metadata changed since (a store
    is completed, or repaired by ``--resume``, by rewriting it)."""
    from .design_curves import sweep_summaries
    from .runner import finished

    errors: dict[str, Errors] = {}
    kept = read if read is not None else {}

    def get(run: Run) -> Errors | None:
        path = out / "runs" / run.key
        if run.key not in errors:
            if not finished(path):
                return None
            token = root_token(path)
            if run.key not in kept or kept[run.key][0] != token:
                kept[run.key] = (token, read_errors(path))
            errors[run.key] = kept[run.key][1]
        return errors[run.key]

    def find(system: str, case: str, point: str, kind: str, seed: int | None) -> Run | None:
        for r in runs:
            if (r.system, r.case, r.point_name, r.kind) == (system, case, point, kind) and (
                seed is None or r.seed == seed
            ):
                return r
        return None

    result: dict[str, Any] = {}
    notes: list[str] = []
    pairs: dict[str, Any] = {}
    for case in study.cases:
        # The gates every system of the case scored, per seed and field.
        common: dict[tuple[int, str], np.ndarray | None] = {}
        estimates = [r for r in runs if r.case == case.name and r.kind == "estimate"]
        loaded = [(r, get(r)) for r in estimates]
        complete = all(e is not None for _, e in loaded)
        for seed in study.seeds:
            group = [e for r, e in loaded if r.seed == seed and e is not None]
            for name in scored_names(group[0]) if group else FIELDS:
                if not complete or not group or any(name not in e.fields for e in group):
                    common[(seed, name)] = None
                    continue
                if not all(group[0].same_grid(e) for e in group):
                    common[(seed, name)] = None
                    continue
                mask = np.ones_like(group[0].fields[name], dtype=bool)
                for e in group:
                    mask &= np.isfinite(e.fields[name])
                common[(seed, name)] = mask
        for system in study.systems:
            for point in [p for p in {r.point_name for r in estimates if r.system == system.name}]:
                entry = _score_point(
                    study, system.name, case.name, point, find, get, common, beamwidths, notes
                )
                key = f"{system.name}/{case.name}/{point}"
                if entry is not None and "ZDR" in entry:
                    calibrated = [
                        r
                        for r in runs
                        if (r.system, r.case, r.point_name) == (system.name, case.name, point)
                        and r.kind.startswith(CALIBRATION)
                    ]
                    entry["ZDR"]["calibration"] = _calibration(
                        find(system.name, case.name, point, "estimate", study.seeds[0]),
                        calibrated,
                        get,
                        (patterns or {}).get(key) or {},
                    )
                if entry is not None:
                    result.setdefault(system.name, {}).setdefault(case.name, {})[point] = entry
        pairs[case.name] = case_pairs(study, case.name, result, find, get, common, beamwidths)
    result["_study"] = {
        "format": "pasim-study-scores/1",
        "patterns": patterns or {},
        "study": study.file,
        "title": study.title,
        "reference_system": study.reference,
        "seeds": study.seeds,
        "beamwidths_deg": beamwidths,
        "notes": sorted(set(notes)),
        "rankings": rankings(study, result, pairs),
        "pairs": pairs,
        "cases": {
            c.name: {
                "truth": c.truth,
                "sector_deg": list(c.sector),
                "elevation_deg": c.elevation,
                "sweeps": c.sweeps,
                "interpolation": c.interpolation,
            }
            for c in study.cases
        },
    }
    result["_study"]["sweeps"] = sweep_summaries(study, result, patterns or {})
    return result


def _calibration(
    estimate: Run | None, calibrated: list[Run], get: Any, pattern: dict[str, Any]
) -> dict[str, Any] | None:
    """A point's ZDR bias along azimuth under each calibration, against its H/V ratio (None:
    the antenna has no calibration choice, or a run or the pattern is missing)."""
    from .calibration import azimuth_profile, zdr_calibration

    own = pattern.get("calibration")
    if not calibrated or estimate is None or not own or "hv_ratio_db" not in pattern:
        return None
    profiles = {}
    for kind, run in [(f"{CALIBRATION}{own}", estimate)] + [(r.kind, r) for r in calibrated]:
        e = get(run)
        if e is None or "ZDR" not in e.fields:
            return None
        profiles[kind.removeprefix(CALIBRATION)] = azimuth_profile(e.fields["ZDR"])
    # The ratio the broadside radar constant leaves: relative to the broadside one.
    ratio = np.asarray(pattern["hv_ratio_db"], dtype=np.float64)
    ratio = ratio - float(pattern.get("hv_ratio_broadside_db", 0.0))
    azimuth = np.asarray(pattern["azimuth_deg"], dtype=np.float64)
    if any(p.shape != ratio.shape for p in profiles.values()):
        return None
    return zdr_calibration(own, profiles, azimuth, ratio)


def _score_point(
    study: Study,
    system: str,
    case: str,
    point: str,
    find: Any,
    get: Any,
    common: dict[tuple[int, str], np.ndarray | None],
    beamwidths: dict[str, float],
    notes: list[str],
) -> dict[str, Any] | None:
    est = [get(find(system, case, point, "estimate", s)) for s in study.seeds]
    own = [get(find(system, case, point, "expected", s)) for s in study.seeds]
    free = get(find(system, case, point, "sidelobe_free", None))
    short = get(find(system, case, point, "short_pulse", None))
    if any(e is None for e in est + own) or free is None or short is None:
        return None
    ref_run = [find(study.reference, case, "-", "expected", s) for s in study.seeds]
    ref = [get(r) if r is not None else None for r in ref_run]
    if any(r is None for r in ref_run):
        notes.append(f"reference system {study.reference} has no unswept run: no reference")
    block = _block_beams(est[0].azimuth, beamwidths.get(f"{system}/{case}/{point}"))
    out: dict[str, Any] = {}
    for name in scored_names(est[0]):
        if name not in est[0].fields:
            continue
        period = est[0].periods.get(name)
        req = est[0].requirements[name]
        e = [x.fields[name] for x in est]
        # The noise term of every statistic of this field: estimate minus own expected level.
        noise = (
            [wrap(x - o.fields[name], period) for x, o in zip(e, own, strict=True)]
            if all(name in o.fields and o.same_grid(est[0]) for o in own)
            else None
        )

        entry = statistics(e, block, req, noise)
        if name in est[0].products:
            entry["product"] = "algorithm: error against the same algorithm on the truth"
        entry["units"] = est[0].units.get(name, "")
        entry["requirement_bias"], entry["requirement_std"] = req
        entry["reference"] = _against(est, name, period, block, req, ref, noise=noise)
        entry["own_expected"] = _against(est, name, period, block, req, own, noise=noise)
        masks = [common.get((s, name)) for s in study.seeds]
        if all(m is not None for m in masks):
            full = [m for m in masks if m is not None]
            c = statistics(
                [np.where(m, x, np.nan) for m, x in zip(full, e, strict=True)], block, req, noise
            )
            c["reference"] = _against(est, name, period, block, req, ref, masks, noise)
            c["own_expected"] = _against(est, name, period, block, req, own, masks, noise)
            entry["common"] = c
        else:
            entry["common"] = None
        if (
            name in free.fields
            and name in short.fields
            and free.same_grid(est[0])
            and short.same_grid(est[0])
        ):
            # Seeds side by side along range: a beam's gates of every seed stay in one block.
            entry["budget"] = budget(
                np.concatenate(e, axis=1),
                np.concatenate([o.fields[name] for o in own], axis=1),
                np.concatenate([free.fields[name]] * len(e), axis=1),
                np.concatenate([short.fields[name]] * len(e), axis=1),
                period,
                block,
            )
        else:
            entry["budget"] = None
            notes.append(f"{system}/{case}/{point}: the references' grids differ: no budget")
        out[name] = entry
    return out


def _against(
    est: list[Errors],
    name: str,
    period: float | None,
    block: int,
    req: tuple[float, float],
    others: list[Any],
    masks: list[np.ndarray | None] | None = None,
    noise: list[np.ndarray] | None = None,
) -> dict[str, Any] | None:
    """Statistics of each seed's estimate minus another store's level (None: not comparable)."""
    ds = []
    for i, x in enumerate(est):
        o = others[i]
        if o is None or name not in o.fields or not x.same_grid(o):
            return None
        d = wrap(x.fields[name] - o.fields[name], period)
        if masks is not None:
            m = masks[i]
            if m is None:
                return None
            d = np.where(m, d, np.nan)
        ds.append(d)
    return statistics(ds, block, req, noise)


def case_pairs(
    study: Study,
    case: str,
    result: dict[str, Any],
    find: Any,
    get: Any,
    common: dict[tuple[int, str], np.ndarray | None],
    beamwidths: dict[str, float],
) -> dict[str, list[dict[str, Any]]]:
    """Per field, every pair of the case's scored unswept systems compared on the gates every
    system scored, seed by seed (:func:`.intervals.paired`): ``a`` has the smaller std."""
    out: dict[str, list[dict[str, Any]]] = {}
    scored = [s.name for s in study.systems if "-" in result.get(s.name, {}).get(case, {})]
    loaded: dict[str, tuple[list[Any], list[Any], int]] = {}
    for name in scored:
        est = [get(find(name, case, "-", "estimate", s)) for s in study.seeds]
        own = [get(find(name, case, "-", "expected", s)) for s in study.seeds]
        if any(x is None for x in est + own):
            continue
        block = _block_beams(est[0].azimuth, beamwidths.get(f"{name}/{case}/-"))
        loaded[name] = (est, own, block)
    for field in FIELDS:
        maybe = [common.get((s, field)) for s in study.seeds]
        masks = [m for m in maybe if m is not None]
        if len(masks) < len(maybe):
            continue
        series: dict[str, tuple[list[np.ndarray], list[np.ndarray] | None, int]] = {}
        for name, (est, own, block) in loaded.items():
            if field not in est[0].fields:
                continue
            period = est[0].periods.get(field)
            e = [np.where(m, x.fields[field], np.nan) for m, x in zip(masks, est, strict=True)]
            noise = (
                [
                    wrap(x.fields[field] - o.fields[field], period)
                    for x, o in zip(est, own, strict=True)
                ]
                if all(field in o.fields and o.same_grid(x) for x, o in zip(est, own, strict=True))
                else None
            )
            series[name] = (e, noise, block)
        names = sorted(series, key=lambda k: float(np.mean([np.nanstd(x) for x in series[k][0]])))
        rows = []
        for i, a in enumerate(names):
            for b in names[i + 1 :]:
                ea, na, ba = series[a]
                eb, nb, bb = series[b]
                rows.append({"a": a, "b": b, **paired(ea, eb, max(ba, bb), na, nb)})
        out[field] = rows
    return out


def rankings(
    study: Study, result: dict[str, Any], pairs: dict[str, Any] | None = None
) -> dict[str, Any]:
    """Per case and field, the unswept systems in groups, best first. With the paired
    comparisons (``pairs``, on common gates): systems ordered by their common-gate std, and a
    system starts a new group only where it is ranked (both paired intervals of its
    difference exclude zero) against every system of the group before. Without them (the
    systems share no gates): by std on own gates, a new group where the scene intervals
    separate."""
    out: dict[str, Any] = {}
    for case in study.cases:
        for name in FIELDS:
            rows_p = (pairs or {}).get(case.name, {}).get(name)
            if rows_p:
                order: list[str] = []
                for r in rows_p:
                    order += [k for k in (r["a"], r["b"]) if k not in order]
                ranked = {(r["a"], r["b"]) for r in rows_p if r["ranked"]}
                groups_p: list[list[str]] = []
                for sname in order:
                    if groups_p and all((g, sname) in ranked for g in groups_p[-1]):
                        groups_p.append([sname])
                    elif groups_p:
                        groups_p[-1].append(sname)
                    else:
                        groups_p.append([sname])
                out.setdefault(case.name, {})[name] = groups_p
                continue
            rows = []
            for system in study.systems:
                s = result.get(system.name, {}).get(case.name, {}).get("-", {}).get(name)
                if s and math.isfinite(s["std"]):
                    rows.append((s["std"], s["std_ci"], system.name))
            rows.sort()
            groups: list[list[str]] = []
            top = -math.inf  # the highest upper bound of the current group
            for _, ci, sname in rows:
                if groups and not (math.isfinite(ci[0]) and ci[0] > top):
                    groups[-1].append(sname)
                    top = max(top, ci[1])
                else:
                    groups.append([sname])
                    top = ci[1]
            out.setdefault(case.name, {})[name] = groups
    return out


def _stat_rows(base: dict[str, Any], against: str, st: dict[str, Any]) -> list[dict[str, Any]]:
    """A statistic's quantities as tidy rows; an interval ``[lo, hi]`` as two rows."""
    rows = []
    for q in ("std", "std_ci", "robust_std", "bias", "bias_ci", "count", "pass"):
        v = st[q]
        pairs = ((f"{q}_lo", v[0]), (f"{q}_hi", v[1])) if isinstance(v, list) else ((q, v),)
        rows += [{**base, "against": against, "quantity": k, "value": x} for k, x in pairs]
    for kind in ("noise_ci", "scene_ci"):
        for q in ("std", "bias"):
            lo, hi = (st.get(kind) or {}).get(q, [math.nan, math.nan])
            prefix = f"{q}_{kind.removesuffix('_ci')}_ci"
            rows += [
                {**base, "against": against, "quantity": f"{prefix}_{end}", "value": x}
                for end, x in (("lo", lo), ("hi", hi))
            ]
    return rows


def _calibration_rows(base: dict[str, Any], cal: dict[str, Any]) -> list[dict[str, Any]]:
    """The ZDR bias along azimuth against the H/V ratio, per calibration, as tidy rows
    (``against`` is ``calibration_<kind>``; the ratio's own spread is ``hv_ratio``)."""
    rows = [{**base, "against": "hv_ratio", "quantity": "std_db", "value": cal["hv_ratio_std_db"]}]
    for kind, fit in cal.get("against_ratio", {}).items():
        rows += [
            {**base, "against": f"calibration_{kind}", "quantity": q, "value": v}
            for q, v in fit.items()
        ]
    return rows


def csv_rows(result: dict[str, Any]) -> list[dict[str, Any]]:
    """One tidy row per system, case, point, field, gate set, reference and quantity."""
    rows = []
    for system, cases in result.items():
        if system.startswith("_"):
            continue
        for case, points in cases.items():
            for point, fields in points.items():
                for name, s in fields.items():
                    base = {"system": system, "case": case, "point": point, "field": name}
                    for gates, stats in (("own", s), ("common", s.get("common"))):
                        for against in ("raw", "reference", "own_expected"):
                            st = stats if against == "raw" else (stats or {}).get(against)
                            if st is not None:
                                rows += _stat_rows({**base, "gates": gates}, against, st)
                    own = {**base, "gates": "own"}
                    rows += [
                        {**own, "against": "budget", "quantity": q, "value": v}
                        for q, v in (s.get("budget") or {}).items()
                        if isinstance(v, (int, float))
                    ]
                    if s.get("calibration"):
                        rows += _calibration_rows(own, s["calibration"])
    return rows


def write_scores(out: Path, result: dict[str, Any]) -> None:
    from pasim_graph.outputs import write_atomic

    write_atomic(out / "scores.json", json.dumps(json_safe(result), indent=1) + "\n")
    buf = io.StringIO()
    w = csv.DictWriter(
        buf,
        ["system", "case", "point", "field", "gates", "against", "quantity", "value"],
        lineterminator="\n",
    )
    w.writeheader()
    for row in csv_rows(result):
        v = row["value"]
        row["value"] = "" if isinstance(v, float) and not math.isfinite(v) else v
        w.writerow(row)
    write_atomic(out / "scores.csv", buf.getvalue())
