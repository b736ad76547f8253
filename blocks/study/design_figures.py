"""The report's design figures: the ZDR bias along azimuth under each calibration against the
two-way H/V ratio (paper figures 9e-11e), and a swept system's design curves (each moment's
std, the peak sidelobe and the error budget against the swept parameter), with the verdicts
``scores.json`` computed for them put in words.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .figures import Figure, canvas, point_value, uri
from .statistics import FIELDS

#: The budget's parts, bottom to top of a stacked bar, with their colours.
PARTS = ("main_lobe", "range", "sidelobes", "estimator_noise")
PART_LABELS = {
    "main_lobe": "main lobe (beam smoothing)",
    "range": "range response",
    "sidelobes": "sidelobes",
    "estimator_noise": "estimator noise",
}
PART_COLOURS = {
    "main_lobe": "#1f77b4",
    "range": "#9467bd",
    "sidelobes": "#d62728",
    "estimator_noise": "#ff7f0e",
}
#: The moments whose budget a sweep's design figure draws (the paper's Tables 7-8).
SWEEP_BUDGET_FIELDS = ("DBZH", "ZDR", "RHOHV", "PHIDP")
CALIBRATION_STYLE = {"boresight": ("C3", "o"), "per_beam": ("C2", "s")}


def calibration_figure(system: str, cal: dict[str, Any]) -> Figure:
    """The ZDR error along azimuth under each calibration, the H/V ratio drawn over it."""
    az = np.asarray(cal["azimuth_deg"], dtype=np.float64)
    fig = canvas(7.5, 3.6)
    ax = fig.subplots()
    for name, profile in cal["profiles_db"].items():
        colour, marker = CALIBRATION_STYLE.get(name, ("C0", "^"))
        r = cal["against_ratio"][name]["correlation"]
        corr = f"r = {r:.3f}" if r is not None and math.isfinite(r) else "H/V ratio flat"
        own = " (as built)" if name == cal["own"] else ""
        ax.plot(
            az,
            np.asarray(profile, dtype=np.float64),
            color=colour,
            marker=marker,
            ms=3,
            lw=1,
            label=f"ZDR bias, {name.replace('_', '-')} calibration{own}: {corr}",
        )
    ax.plot(
        az,
        cal["hv_ratio_db"],
        color="black",
        ls="--",
        lw=1.2,
        label="two-way H/V ratio, relative to broadside",
    )
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel("beam azimuth (deg)")
    ax.set_ylabel("dB")
    ax.set_title(f"{system}: ZDR bias averaged along range, per beam", fontsize=10)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return Figure(
        f"{system}: ZDR bias along azimuth",
        uri(fig),
        f"ZDR bias of {system} along azimuth under each calibration, with its H/V ratio",
        "Each beam's mean ZDR error against the raw gates (its scored gates); r: the Pearson "
        "correlation of the profile with the two-way H/V power ratio at the beam's own "
        "direction relative to the ratio at broadside (which the boresight radar constant "
        "corrects), measured from the antenna's pattern with the run seed's channel errors.",
    )


def calibration_rows(scores: dict[str, Any], systems: list[str], case: str) -> list[dict]:
    """One row per system and calibration: how its ZDR bias follows the H/V ratio."""
    rows = []
    for system in systems:
        cal = (scores[system].get(case, {}).get("-", {}).get("ZDR") or {}).get("calibration")
        if not cal:
            continue
        for name, a in cal["against_ratio"].items():
            rows.append(
                {
                    "system": system,
                    "calibration": name.replace("_", "-")
                    + (" (as built)" if name == cal["own"] else ""),
                    "hv_std": _num(cal["hv_ratio_std_db"]),
                    "correlation": "n/a: the ratio is flat"
                    if cal.get("hv_ratio_flat")
                    else _num(a["correlation"]),
                    "slope": "n/a" if cal.get("hv_ratio_flat") else _num(a["slope"]),
                    "azimuth_std": _num(a["azimuth_std_db"]),
                    "mean": _num(a["mean_db"]),
                    "beams": a["beams"],
                }
            )
    return rows


def _num(x: Any, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    return f"{x:.{digits}g}"


def sweep_figure(scores: dict[str, Any], system: str, case: str) -> Figure | None:
    """Each moment's std against the swept parameter, with intervals and requirement."""
    points = {p: f for p, f in scores[system].get(case, {}).items() if p != "-"}
    if len(points) < 2:
        return None
    params = point_value(next(iter(points)))
    xkey = next((k for k, v in params.items() if isinstance(v, float)), None)
    if xkey is None:
        return None
    others = [k for k in params if k != xkey]
    names = [n for n in FIELDS if any(n in f for f in points.values())]
    ncol = 3
    nrow = math.ceil(len(names) / ncol)
    fig = canvas(14.0, 3.2 * nrow)
    axes = fig.subplots(nrow, ncol, squeeze=False).ravel()
    for ax, name in zip(axes, names, strict=False):
        series: dict[str, list[tuple[float, dict[str, Any]]]] = {}
        for point, fields in points.items():
            if name not in fields:
                continue
            pv = point_value(point)
            label = ",".join(f"{k}={pv[k]}" for k in others) or "std"
            series.setdefault(label, []).append((float(pv[xkey]), fields[name]))
        req = None
        for label, pts in series.items():
            pts.sort(key=lambda p: p[0])
            xs = np.array([p[0] for p in pts])
            ys = np.array([p[1]["std"] if p[1]["std"] is not None else np.nan for p in pts])
            lo = np.array([(p[1]["std_ci"] or [None])[0] or np.nan for p in pts])
            hi = np.array([(p[1]["std_ci"] or [None, None])[1] or np.nan for p in pts])
            yerr = np.vstack([np.clip(ys - lo, 0, None), np.clip(hi - ys, 0, None)])
            ax.errorbar(xs, ys, yerr=np.nan_to_num(yerr), marker="o", capsize=3, label=label)
            req = pts[0][1]["requirement_std"]
            units = pts[0][1].get("units", "")
        if req is not None:
            ax.axhline(req, color="red", ls="--", lw=1, label=f"requirement {req:g}")
            ax.set_ylabel(f"std against raw ({units})", fontsize=8)
        ax.set_xlabel(xkey, fontsize=8)
        ax.set_title(name, fontsize=10)
        ax.legend(fontsize=7)
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    return Figure(
        f"{system}: std against {xkey}",
        uri(fig),
        f"design curves of {system}: each moment's std against {xkey}",
        "95 % intervals as error bars; the dashed red line is the NEXRAD requirement.",
    )


def sidelobe_figure(scores: dict[str, Any], system: str, case: str) -> Figure | None:
    """The peak sidelobe against the swept parameter, and the error budget of each moment as
    stacked variances (the parts add) with the sidelobe part's interval."""
    summary = scores.get("_study", {}).get("sweeps", {}).get(system, {}).get(case)
    if not summary:
        return None
    param, xs = summary["parameter"], np.asarray(summary["values"], dtype=np.float64)
    names = [n for n in SWEEP_BUDGET_FIELDS if n in summary["fields"]]
    points = scores[system][case]
    keys = [k for k in points if k != "-"]
    keys.sort(key=lambda k: float(point_value(k)[param]))
    fig = canvas(14.0, 6.6)
    axes = fig.subplots(2, 3, squeeze=False).ravel()
    ax = axes[0]
    sl = np.asarray(summary["peak_sidelobe_db"], dtype=np.float64)
    ci = np.asarray(summary["peak_sidelobe_ci"], dtype=np.float64)
    yerr = np.nan_to_num(
        np.vstack([np.clip(sl - ci[:, 0], 0, None), np.clip(ci[:, 1] - sl, 0, None)])
    )
    ax.errorbar(xs, sl, yerr=yerr, marker="o", capsize=3, color="black")
    ax.set_xlabel(param, fontsize=8)
    ax.set_ylabel("peak sidelobe (dB below the peak)", fontsize=8)
    ax.set_title("peak sidelobe of the pattern as built", fontsize=10)
    ax.grid(alpha=0.3)
    width = 0.6 * (float(np.min(np.diff(xs))) if xs.size > 1 else 1.0)
    for ax, name in zip(axes[1:], names, strict=False):
        budgets = [(points[k].get(name) or {}).get("budget") or {} for k in keys]
        units = (points[keys[0]].get(name) or {}).get("units", "")
        bottom = np.zeros(xs.size)
        for part in PARTS:
            v = np.array([(b.get(part) or 0.0) ** 2 for b in budgets])
            ax.bar(xs, v, width, bottom=bottom, color=PART_COLOURS[part], label=PART_LABELS[part])
            if part == "sidelobes":
                f = summary["fields"][name]
                lo = np.array([c[0] for c in f["sidelobes_ci"]], dtype=np.float64) ** 2
                hi = np.array([c[1] for c in f["sidelobes_ci"]], dtype=np.float64) ** 2
                mid = bottom + v
                err = np.nan_to_num(np.vstack([np.clip(v - lo, 0, None), np.clip(hi - v, 0, None)]))
                ax.errorbar(xs, mid, yerr=err, fmt="none", ecolor="black", capsize=3, lw=0.8)
            bottom += v
        total = np.array([(b.get("total") or 0.0) ** 2 for b in budgets])
        ax.scatter(xs, total, marker="_", s=400, color="black", zorder=3, label="total (measured)")
        ax.set_xlabel(param, fontsize=8)
        plain = units in ("", "1", "unitless")
        ax.set_ylabel("error variance" + ("" if plain else f" ({units})²"), fontsize=8)
        ax.set_title(f"{name}: budget against {param}", fontsize=10)
    for ax in axes[1 + len(names) :]:
        ax.set_visible(False)
    if len(names) < axes.size - 1:
        ax = axes[-1]
        ax.set_visible(True)
        for name in names:
            share = 100 * np.asarray(summary["fields"][name]["sidelobes_share"], dtype=np.float64)
            ax.plot(xs, share, marker="o", label=name)
        threshold = summary["fields"][names[0]]["stops_mattering"].get("threshold_share")
        if threshold:
            ax.axhline(100 * threshold, color="red", ls="--", lw=1, label="matters above")
        ax.set_yscale("log")
        ax.set_xlabel(param, fontsize=8)
        ax.set_ylabel("sidelobe part, % of the error variance", fontsize=8)
        ax.set_title("does the sidelobe part matter?", fontsize=10)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3, which="both")
    handles, labels = axes[1].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), fontsize=8)
    return Figure(
        f"{system}: peak sidelobe and error budget against {param}",
        uri(fig),
        f"peak sidelobe and error budget of {system} against {param}",
        "Peak sidelobe: the mean over the sampled beams of the sector with its 95 % interval. "
        "Budget: the parts' variances stacked (they add when uncorrelated), the sidelobe "
        "part's 95 % interval (block bootstrap over beams) as the black bar, the measured "
        "total variance as the black tick. Last panel: the sidelobe part's share of the "
        "variance the parts add up to; below the dashed line it does not matter.",
    )


def _trend(values: list[float], trend: dict[str, Any], param: str, unit: str) -> str:
    finite = [v for v in values if v is not None and math.isfinite(v)]
    if len(finite) < 2 or trend.get("monotone") is None:
        return "too few points for a trend"
    way = "rises" if trend["direction"] == "rising" else "falls"
    if trend["monotone"]:
        verdict = "monotone within the 95 % intervals"
    else:
        verdict = (
            f"not monotone: {len(trend['against'])} step(s) go against it beyond the intervals"
        )
    return f"{way} from {finite[0]:.3g} to {finite[-1]:.3g} {unit} as {param} grows, {verdict}"


def sweep_verdicts(scores: dict[str, Any], system: str, case: str) -> list[str]:
    """The sweep's verdicts of ``scores.json`` in sentences."""
    summary = scores.get("_study", {}).get("sweeps", {}).get(system, {}).get(case)
    if not summary:
        return []
    param = summary["parameter"]
    out = [
        "Peak sidelobe: "
        + _trend(summary["peak_sidelobe_db"], summary["peak_sidelobe_trend"], param, "dB")
        + "."
    ]
    for name in SWEEP_BUDGET_FIELDS:
        f = summary["fields"].get(name)
        if not f:
            continue
        stop = f["stops_mattering"]
        threshold = f"{stop.get('threshold_share', 0.05):.0%} of the error variance"
        shares = [s for s in f["sidelobes_share"] if s is not None and math.isfinite(s)]
        largest = f"largest share {max(shares):.1%}" if shares else "no share"
        if stop["value"] is None:
            when = f"it matters at every swept value (at least {threshold}; {largest})"
        elif not stop["matters_at"]:
            when = (
                f"it does not matter against the other parts anywhere in the sweep (below "
                f"{threshold} at every value; {largest})"
            )
        else:
            when = (
                f"it stops mattering against the other parts from {param} = {stop['value']:g} "
                f"on (below {threshold}; it is at least that at "
                f"{', '.join(f'{v:g}' for v in stop['matters_at'])})"
            )
        out.append(
            f"{name}, sidelobe part of the budget: "
            + _trend(f["sidelobes"], f["sidelobes_trend"], param, "")
            + f"; {when}."
        )
    return out
