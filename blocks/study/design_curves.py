"""Design curves of a swept system: the peak sidelobe and the budget's sidelobe part against
the swept parameter, whether they move one way within their intervals, and from which value
on the sidelobe part stops mattering against the other parts.

"Monotone within the intervals": along the parameter, no step goes against the overall trend
(from the first point to the last) by more than the two points' 95 % intervals allow, that is
with the intervals separated. "Stops mattering": the sidelobe part's share of the error
variance (the parts' variances add) stays below :data:`NEGLIGIBLE_SHARE` from that value on,
in the direction in which it shrinks.
"""

from __future__ import annotations

import math
from typing import Any

from .model import Study, point_name

#: A part whose variance is below this share of the sum of the parts' variances changes the
#: total std by less than 2.5 %: below every budget's 10 % tolerance of adding up.
NEGLIGIBLE_SHARE = 0.05


def monotone(values: list[float], cis: list[list[float]]) -> dict[str, Any]:
    """Whether ``values`` (in the parameter's order) move one way within their intervals."""
    finite = [v for v in values if math.isfinite(v)]
    if len(finite) < 2:
        return {"monotone": None, "direction": "", "against": []}
    rising = finite[-1] >= finite[0]
    against = []
    for i in range(len(values) - 1):
        (lo0, hi0), (lo1, hi1) = cis[i], cis[i + 1]
        if rising and math.isfinite(lo0) and math.isfinite(hi1) and hi1 < lo0:
            against.append(i)
        if not rising and math.isfinite(hi0) and math.isfinite(lo1) and lo1 > hi0:
            against.append(i)
    return {
        "monotone": not against,
        "direction": "rising" if rising else "falling",
        "against": against,  # steps i -> i+1 that go against the trend beyond the intervals
    }


def stops_mattering(xs: list[float], shares: list[float]) -> dict[str, Any]:
    """The parameter value from which on (towards where the share shrinks) the share stays
    below :data:`NEGLIGIBLE_SHARE`: None when it matters at the best swept value too."""
    pairs = [(x, s) for x, s in zip(xs, shares, strict=True) if math.isfinite(s)]
    if not pairs:
        return {"value": None, "matters_at": [], "negligible_at": []}
    # Walk from the end where the share is smallest towards the other.
    if pairs[-1][1] > pairs[0][1]:
        pairs = pairs[::-1]
    value = None
    for x, s in reversed(pairs):
        if s >= NEGLIGIBLE_SHARE:
            break
        value = x
    return {
        "value": value,
        "threshold_share": NEGLIGIBLE_SHARE,
        "matters_at": sorted(x for x, s in pairs if s >= NEGLIGIBLE_SHARE),
        "negligible_at": sorted(x for x, s in pairs if s < NEGLIGIBLE_SHARE),
    }


def _number(v: Any) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    return float(v)


def sweep_summaries(
    study: Study, result: dict[str, Any], patterns: dict[str, Any]
) -> dict[str, Any]:
    """Per swept system and case: the parameter, and per point the peak sidelobe and each
    field's sidelobe part, with the monotony and "stops mattering" verdicts."""
    out: dict[str, Any] = {}
    for sweep in study.sweeps:
        numeric = [k for k, vs in sweep.values.items() if all(_number(v) is not None for v in vs)]
        if len(sweep.values) != 1 or not numeric:
            continue  # design curves need one numeric parameter
        param = numeric[0]
        xs = [float(v) for v in sorted(sweep.values[param])]
        for system in sweep.systems:
            for case in study.cases:
                points = result.get(system, {}).get(case.name, {})
                names = [point_name({param: v}) for v in sorted(sweep.values[param])]
                if not all(n in points for n in names):
                    continue  # not every point finished yet
                keys = [f"{system}/{case.name}/{n}" for n in names]
                sl = [(patterns.get(k) or {}).get("peak_sidelobe_db", math.nan) for k in keys]
                sl_ci = [
                    (patterns.get(k) or {}).get("peak_sidelobe_ci", [math.nan, math.nan])
                    for k in keys
                ]
                entry: dict[str, Any] = {
                    "parameter": param,
                    "values": xs,
                    "peak_sidelobe_db": sl,
                    "peak_sidelobe_ci": sl_ci,
                    "peak_sidelobe_trend": monotone(sl, sl_ci),
                    "fields": {},
                }
                for name in next(iter(points.values())):
                    budgets = [(points[n].get(name) or {}).get("budget") or {} for n in names]
                    if not all("sidelobes" in b for b in budgets):
                        continue
                    part = [b["sidelobes"] for b in budgets]
                    ci = [b.get("ci", {}).get("sidelobes", [math.nan, math.nan]) for b in budgets]
                    shares = [b["variance_share"]["sidelobes"] for b in budgets]
                    entry["fields"][name] = {
                        "sidelobes": part,
                        "sidelobes_ci": ci,
                        "sidelobes_share": shares,
                        "sidelobes_trend": monotone(part, ci),
                        "stops_mattering": stops_mattering(xs, shares),
                    }
                out.setdefault(system, {})[case.name] = entry
    return out
