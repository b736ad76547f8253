"""The report's design figures: the ZDR bias along azimuth under each calibration against the
two-way H/V ratio (paper figures 9e-11e), and a swept system's design curves (each moment's
std against the swept parameter).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .figures import Figure, canvas, point_value, uri
from .scores import FIELDS

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
