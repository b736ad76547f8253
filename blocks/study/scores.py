"""A study's statistics: three references, own and common gates, intervals, error budget.

Every statistic is of a gate's error (estimate minus reference), velocity and phi_DP on their
circles (the scorer's ``period``): against the raw NEXRAD gates (the scorer's ``error_*``),
against the reference system's ``expected`` level and against the system's own. Intervals
(95 %) come from the seeds when there are several (Student's t on the per-seed values), else
from a block bootstrap over whole beams in blocks of about three beamwidths: neighbouring
gates and beams are correlated, so a naive standard error would be far too small.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pasim_graph.serialize import json_safe

from ..signals import MOMENT_FIELDS
from .intervals import t_interval
from .model import Study
from .plan import CALIBRATION, Run

FIELDS = MOMENT_FIELDS
BOOTSTRAP = 1000
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

    def same_grid(self, other: Errors) -> bool:
        return (
            self.azimuth.shape == other.azimuth.shape
            and self.range.shape == other.range.shape
            and bool(np.allclose(self.azimuth, other.azimuth, atol=1e-3))
            and bool(np.allclose(self.range, other.range, atol=1e-3))
        )


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
    return Errors(
        np.asarray(sweep[dim].values, dtype=np.float64),
        np.asarray(sweep["range"].values, dtype=np.float64),
        fields,
        periods,
        reqs,
        units,
    )


def wrap(d: np.ndarray, period: float | None) -> np.ndarray:
    """A difference on the circle of ``period`` into [-period/2, period/2)."""
    if not period:
        return d
    return (d + period / 2) % period - period / 2


def robust_std(x: np.ndarray) -> float:
    if x.size < 2:
        return float("nan")
    return float(MAD_TO_STD * np.median(np.abs(x - np.median(x))))


def _beam_sums(d: np.ndarray, block: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ok = np.isfinite(d)
    x = np.where(ok, d, 0.0)
    n, s1, s2 = ok.sum(1).astype(float), x.sum(1), (x * x).sum(1)
    starts = np.arange(0, d.shape[0], block)
    return (np.add.reduceat(n, starts), np.add.reduceat(s1, starts), np.add.reduceat(s2, starts))


def bootstrap(d: np.ndarray, block: int, seed: int = 0) -> tuple[list[float], list[float]]:
    """95 % intervals of (std, bias) of the finite values of ``d`` (beam, range), resampling
    whole blocks of ``block`` beams with replacement."""
    n, s1, s2 = _beam_sums(d, max(1, block))
    if n.size < 2 or n.sum() < 3:
        return [math.nan, math.nan], [math.nan, math.nan]
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, n.size, size=(BOOTSTRAP, n.size))
    N, S1, S2 = n[pick].sum(1), s1[pick].sum(1), s2[pick].sum(1)
    ok = N > 1
    bias = S1[ok] / N[ok]
    var = np.maximum(S2[ok] - S1[ok] ** 2 / N[ok], 0.0) / (N[ok] - 1)
    std = np.sqrt(var)
    q = [2.5, 97.5]
    return [float(v) for v in np.percentile(std, q)], [float(v) for v in np.percentile(bias, q)]


def statistics(
    per_seed: list[np.ndarray], block: int, requirement: tuple[float, float]
) -> dict[str, Any]:
    """Std, robust spread, bias, count and their intervals of per-seed errors (beam, range)."""
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
    if len(per_seed) > 1:
        std_ci, bias_ci = t_interval([r[0] for r in rows]), t_interval([r[2] for r in rows])
        interval = f"Student's t across {len(per_seed)} seeds"
    else:
        std_ci, bias_ci = bootstrap(per_seed[0], block)
        interval = f"block bootstrap over beams, blocks of {block} beams, {BOOTSTRAP} resamples"
    req_b, req_s = requirement
    return {
        "std": std,
        "std_ci": std_ci,
        "robust_std": rstd,
        "bias": bias,
        "bias_ci": bias_ci,
        "count": count,
        "pass": bool(count > 1 and abs(bias) <= req_b and std <= req_s),
        "interval": interval,
    }


def std_intervals(
    terms: dict[str, np.ndarray], ok: np.ndarray, block: int, seed: int = 0
) -> dict[str, list[float]]:
    """95 % intervals of the std of each term (beam, range) on the gates ``ok``, by one block
    bootstrap over beams shared by all terms (the same resampled beams for every part)."""
    sums = {k: _beam_sums(np.where(ok, d, np.nan), max(1, block)) for k, d in terms.items()}
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
) -> dict[str, Any]:
    """Scores of every system, case and point whose runs are all finished; ``patterns``: the
    antenna figures the runner measured (:mod:`.patterns`), by ``SYSTEM/CASE/POINT``."""
    from .runner import finished
    from .sweeps import sweep_summaries

    errors: dict[str, Errors] = {}

    def get(run: Run) -> Errors | None:
        path = out / "runs" / run.key
        if run.key not in errors:
            if not finished(path):
                return None
            errors[run.key] = read_errors(path)
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
    for case in study.cases:
        # The gates every system of the case scored, per seed and field.
        common: dict[tuple[int, str], np.ndarray | None] = {}
        estimates = [r for r in runs if r.case == case.name and r.kind == "estimate"]
        loaded = [(r, get(r)) for r in estimates]
        complete = all(e is not None for _, e in loaded)
        for seed in study.seeds:
            group = [e for r, e in loaded if r.seed == seed and e is not None]
            for name in FIELDS:
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
    result["_study"] = {
        "format": "pasim-study-scores/1",
        "patterns": patterns or {},
        "study": study.file,
        "title": study.title,
        "reference_system": study.reference,
        "seeds": study.seeds,
        "beamwidths_deg": beamwidths,
        "notes": sorted(set(notes)),
        "rankings": rankings(study, result),
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
    for name in FIELDS:
        if name not in est[0].fields:
            continue
        period = est[0].periods.get(name)
        req = est[0].requirements[name]
        e = [x.fields[name] for x in est]

        entry = statistics(e, block, req)
        entry["units"] = est[0].units.get(name, "")
        entry["requirement_bias"], entry["requirement_std"] = req
        entry["reference"] = _against(est, name, period, block, req, ref)
        entry["own_expected"] = _against(est, name, period, block, req, own)
        masks = [common.get((s, name)) for s in study.seeds]
        if all(m is not None for m in masks):
            full = [m for m in masks if m is not None]
            c = statistics(
                [np.where(m, x, np.nan) for m, x in zip(full, e, strict=True)], block, req
            )
            c["reference"] = _against(est, name, period, block, req, ref, masks)
            c["own_expected"] = _against(est, name, period, block, req, own, masks)
            entry["common"] = c
        else:
            entry["common"] = None
        if (
            name in free.fields
            and name in short.fields
            and free.same_grid(est[0])
            and short.same_grid(est[0])
        ):
            entry["budget"] = budget(
                np.concatenate(e),
                np.concatenate([o.fields[name] for o in own]),
                np.concatenate([free.fields[name]] * len(e)),
                np.concatenate([short.fields[name]] * len(e)),
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
    return statistics(ds, block, req)


def rankings(study: Study, result: dict[str, Any]) -> dict[str, Any]:
    """Per case and field, the unswept systems by std against the raw gates on own gates, in
    groups: a system starts a new group only where its interval separates from the last."""
    out: dict[str, Any] = {}
    for case in study.cases:
        for name in FIELDS:
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
