"""``DIR/report.html``: a study's one self-contained page for a design review.

Built from the study's folder alone (``pasim-study.json``, ``scores.json`` and the stores under
``runs/``), so ``pasim study DIR --report-only`` rebuilds it without rerunning anything. Every
figure is drawn with matplotlib's Agg canvas and embedded as a PNG data URI; the page loads no
script, font or image from anywhere. The HTML comes from a jinja2 template
(``templates/report.html.j2``, autoescaped).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pasim_graph.outputs import write_atomic

from .design_figures import (
    PART_COLOURS,
    PART_LABELS,
    PARTS,
    calibration_figure,
    calibration_rows,
    sidelobe_figure,
    sweep_figure,
    sweep_verdicts,
)
from .figures import Drawing, Figure, canvas, uri
from .hardware_figures import hardware_figure, hardware_table
from .panel_figures import histogram_figure, ppi_fields, ppi_figure
from .runner import MANIFEST, StudyError, read_manifest
from .statistics import FIELDS

REPORT = "report.html"
TEMPLATES = Path(__file__).parent / "templates"
PART_TEXT = {
    "main_lobe": (
        "the weather averaged over the main lobe of a sidelobe-free beam of the system's own "
        "beamwidth, with an ideal short pulse, against the raw gates: bought down by a "
        "narrower beam (a larger aperture), nothing else"
    ),
    "range": (
        "the pulse and matched filter's range response against that short pulse: bought down "
        "by a shorter pulse or a wider bandwidth (pulse compression)"
    ),
    "sidelobes": (
        "the system's noise-free level against the sidelobe-free beam of the same width: "
        "weather leaking in through the sidelobes, bought down by a lower sidelobe level "
        "(taper, element errors, phase-shifter bits)"
    ),
    "estimator_noise": (
        "the estimate against the system's own noise-free level: the statistics of a finite "
        "number of pulses and receiver noise, bought down by more pulses (a slower scan) or "
        "more sensitivity"
    ),
    "bias": (
        "the mean error: calibration, cross-polar coupling and the log of an averaged power; "
        "it is not part of the spread and is shown beside it"
    ),
}


@dataclass
class CaseReport:
    name: str
    points: list[str]
    table: list[dict[str, Any]] = field(default_factory=list)
    products: list[dict[str, Any]] = field(default_factory=list)
    rankings: list[dict[str, Any]] = field(default_factory=list)
    budget_rows: list[dict[str, Any]] = field(default_factory=list)
    calibration_rows: list[dict[str, Any]] = field(default_factory=list)
    sweep_verdicts: dict[str, list[str]] = field(default_factory=dict)
    figures: dict[str, list[Figure]] = field(default_factory=dict)
    truth: str = ""


def case_truth_text(case: dict[str, Any] | None) -> str:
    """What a case's weather is, in words: file, sector, elevation, and how it fills elevation."""
    if not case:
        return ""
    truth = Path(case["truth"]).name if case.get("truth") else "the bundled scene (KLBB)"
    start, stop = case.get("sector_deg", [0, 360])
    how = (
        "every sweep of the volume, "
        f"{case.get('interpolation', 'nearest')} between sweeps in elevation"
        if case.get("sweeps") == "volume"
        else "its nearest sweep, taken as uniform in elevation"
    )
    return (
        f"Truth: {truth}, azimuth {start:g} to {stop:g} deg, beams at "
        f"{case.get('elevation_deg', 0.5):g} deg elevation; the weather is {how}."
    )


def format_number(x: Any, digits: int = 3) -> str:
    """A number as the report prints it: ``digits`` significant digits, integers with
    thousands separators, "n/a" for None and non-finite values."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    if isinstance(x, int):
        return f"{x:,}"
    return f"{x:.{digits}g}"


def _ci(ci: Any) -> str:
    if not ci or any(v is None for v in ci):
        return "[n/a]"
    return f"[{format_number(ci[0])}, {format_number(ci[1])}]"


def _store(out: Path, system: str, case: str, point: str, seed: int) -> Path:
    return out / "runs" / system / case / point / f"estimate-seed{seed}.zarr"


def load(out: Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """The manifest and scores of a study folder (StudyError when either is missing)."""
    manifest, scores = out / MANIFEST, out / "scores.json"
    if not manifest.is_file():
        raise StudyError(f"{out}: not a study folder ({MANIFEST} missing)")
    if not scores.is_file():
        raise StudyError(f"{out}: no scores.json yet (no system has all its runs finished)")
    state = read_manifest(manifest)
    try:
        return state, json.loads(scores.read_text())
    except (OSError, ValueError) as exc:
        raise StudyError(f"{out}: unreadable study files ({exc})") from None


def _systems(scores: dict[str, Any]) -> list[str]:
    return [k for k in scores if not k.startswith("_")]


def product_names(scores: dict[str, Any], systems: list[str], case: str) -> list[str]:
    """The algorithm products any system of the case scored (``algorithm.*`` blocks), in the
    order of their first appearance."""
    names: dict[str, None] = {}
    for system in systems:
        for fields in scores[system].get(case, {}).values():
            names.update({n: None for n, s in fields.items() if s.get("product")})
    return list(names)


def summary_rows(
    scores: dict[str, Any],
    systems: list[str],
    case: str,
    names: tuple[str, ...] | list[str] = FIELDS,
) -> list[dict[str, Any]]:
    """One row per moment (or ``names``) and system point: every number of the summary
    table."""
    rows = []
    for name in names:
        cells = []
        req = None
        for system in systems:
            for point, fields in scores[system].get(case, {}).items():
                s = fields.get(name)
                if s is None:
                    continue
                req = req or (s["requirement_bias"], s["requirement_std"], s.get("units", ""))
                ref = s.get("reference") or {}
                com = s.get("common") or {}
                cells.append(
                    {
                        "system": system if point == "-" else f"{system} ({point})",
                        "std": format_number(s["std"]),
                        "std_noise_ci": _ci((s.get("noise_ci") or {}).get("std")),
                        "std_scene_ci": _ci((s.get("scene_ci") or {}).get("std", s["std_ci"])),
                        "robust": format_number(s["robust_std"]),
                        "bias": format_number(s["bias"]),
                        "bias_noise_ci": _ci((s.get("noise_ci") or {}).get("bias")),
                        "bias_scene_ci": _ci((s.get("scene_ci") or {}).get("bias", s["bias_ci"])),
                        "count": format_number(s["count"]),
                        "pass": bool(s["pass"]),
                        "reference_std": format_number(ref.get("std")),
                        "own_std": format_number((s.get("own_expected") or {}).get("std")),
                        "common_std": format_number(com.get("std")),
                        "common_count": format_number(com.get("count")),
                        "common_pass": com.get("pass"),
                    }
                )
        if cells and req is not None:
            rows.append(
                {
                    "field": name,
                    "req_bias": req[0],
                    "req_std": req[1],
                    "units": req[2],
                    "cells": cells,
                }
            )
    return rows


def _rankings(scores: dict[str, Any], case: str) -> list[dict[str, Any]]:
    out = []
    pairs = scores["_study"].get("pairs", {}).get(case, {})
    for name, groups in scores["_study"].get("rankings", {}).get(case, {}).items():
        if not groups:
            continue
        if len(groups) == 1:
            text = (
                f"no ranking: {', '.join(groups[0])} are not separated"
                if len(groups[0]) > 1
                else f"one system ({groups[0][0]})"
            )
        else:
            parts = [
                " = ".join(g) + (" (not separated: not ranked)" if len(g) > 1 else "")
                for g in groups
            ]
            text = " < ".join(parts)
        out.append(
            {
                "field": name,
                "text": text,
                "ranked": len(groups) > 1,
                "pairs": [_pair_row(r) for r in pairs.get(name, [])],
            }
        )
    return out


def _pair_row(r: dict[str, Any]) -> dict[str, Any]:
    """One paired comparison in words: the difference, both intervals, what separated it."""
    by = r.get("separated_by", [])
    if r.get("ranked"):
        said = f"{r['a']} < {r['b']}: separated by both the noise and the scene interval"
    elif by == ["noise"]:
        said = (
            f"unranked: the noise interval separates {r['a']} from {r['b']} on this weather, "
            "the scene interval does not"
        )
    elif by == ["scene"]:
        said = "unranked within noise (the scene interval alone excludes zero)"
    else:
        said = "unranked within noise"
    return {
        "a": r["a"],
        "b": r["b"],
        "difference": format_number(r["difference"]),
        "noise_ci": _ci(r["noise_ci"]),
        "scene_ci": _ci(r["scene_ci"]),
        "unpaired_ci": _ci(r["unpaired_scene_ci"]),
        "ratio": format_number(r["paired_over_unpaired"], 2),
        "verdict": said,
    }


def _budget_rows(scores: dict[str, Any], systems: list[str], case: str) -> list[dict[str, Any]]:
    rows = []
    for system in systems:
        for point, fields in scores[system].get(case, {}).items():
            for name in FIELDS:
                b = (fields.get(name) or {}).get("budget")
                if not b or "total" not in b:
                    continue
                rows.append(
                    {
                        "system": system if point == "-" else f"{system} ({point})",
                        "field": name,
                        "units": fields[name].get("units", ""),
                        **{
                            k: format_number(b.get(k))
                            for k in (*PARTS, "bias", "total", "quadrature_sum")
                        },
                        "count": format_number(b.get("count")),
                        "adds_up": b.get("adds_up"),
                        "note": b.get("note", ""),
                        "largest": max(PARTS, key=lambda k: b.get(k) or 0.0),
                    }
                )
    return rows


def budget_figure(scores: dict[str, Any], systems: list[str], case: str) -> Figure | None:
    """Stacked bars per system and moment: each part's variance, the total's drawn over."""
    bars: dict[str, list[tuple[str, dict[str, Any]]]] = {}
    for system in systems:
        for point, fields in scores[system].get(case, {}).items():
            label = system if point == "-" else f"{system}\n{point}"
            for name in FIELDS:
                b = (fields.get(name) or {}).get("budget")
                if b and "total" in b:
                    bars.setdefault(name, []).append((label, b))
    if not bars:
        return None
    names = [n for n in FIELDS if n in bars]
    ncol = 3
    nrow = math.ceil(len(names) / ncol)
    width = max(3, len(max(bars.values(), key=len)))
    fig = canvas(min(16.0, 1.6 * width * ncol), 3.4 * nrow)
    axes = fig.subplots(nrow, ncol, squeeze=False).ravel()
    for ax, name in zip(axes, names, strict=False):
        units = (scores[systems[0]].get(case, {}).get("-", {}).get(name) or {}).get("units", "")
        x = np.arange(len(bars[name]))
        bottom = np.zeros(x.size)
        for part in PARTS:
            v = np.array([(b.get(part) or 0.0) ** 2 for _, b in bars[name]])
            ax.bar(
                x, v, bottom=bottom, color=PART_COLOURS[part], label=PART_LABELS[part], width=0.6
            )
            bottom += v
        total = np.array([(b.get("total") or 0.0) ** 2 for _, b in bars[name]])
        ax.scatter(x, total, marker="_", s=600, color="black", zorder=3, label="total (measured)")
        ax.set_xticks(x, [lab for lab, _ in bars[name]], fontsize=8)
        ax.set_title(f"{name}: error variance against the raw gates")
        ax.set_ylabel(f"variance ({units})²" if units not in ("", "1", "unitless") else "variance")
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), fontsize=9)
    return Figure(
        "Error budget",
        uri(fig),
        f"stacked error-variance budget of every system for {', '.join(names)}",
        "Each bar stacks the squares of the parts (their variances add when the parts are "
        "uncorrelated); the black tick is the measured total variance.",
    )


def _open(path: Path) -> tuple[Any, dict[str, Any]] | None:
    from pasim_graph.store import open_sweep

    try:
        return open_sweep(path)
    except Exception:  # a store that cannot be read: its panels are left out, named
        return None


def build(out: Path, draw: Drawing | None = None) -> dict[str, Any]:
    """Everything the template shows, figures drawn (by ``draw``: here by default)."""
    draw = draw or Drawing()
    from pasim_graph import __version__

    # The stores' sweeps travel to the figures' tasks as lazy arrays naming their files: from
    # a worker started in another folder, a relative path would name nothing.
    out = out.absolute()
    manifest, scores = load(out)
    meta = scores.get("_study", {})
    systems = _systems(scores)
    seeds = meta.get("seeds") or [0]
    cases: dict[str, CaseReport] = {}
    notes: list[str] = list(meta.get("notes", []))
    graphs: dict[str, str] = {}
    versions: set[str] = set()
    for system in systems:
        for case in scores[system]:
            cases.setdefault(case, CaseReport(case, []))
    for case, rep in cases.items():
        rep.truth = case_truth_text(meta.get("cases", {}).get(case))
        rep.table = summary_rows(scores, systems, case)
        rep.products = summary_rows(scores, systems, case, product_names(scores, systems, case))
        rep.rankings = _rankings(scores, case)
        rep.budget_rows = _budget_rows(scores, systems, case)
        rep.figures["budget"] = [draw(budget_figure, scores, systems, case)]
        panels: list[tuple[str, Any]] = []
        for system in systems:
            pts = list(scores[system].get(case, {}))
            if not pts:
                continue
            point = "-" if "-" in pts else pts[0]
            path = _store(out, system, case, point, seeds[0])
            opened = _open(path)
            if opened is None:
                notes.append(f"{path.relative_to(out)}: unreadable; its panels are left out")
                continue
            sweep, root = opened
            graphs.setdefault(system, str(root.get("graph", "")))
            versions.add(str(root.get("pasim_graph_version", "?")))
            panels.append((system if point == "-" else f"{system} ({point})", sweep))
        rep.figures["ppi"] = [draw(ppi_figure, n, panels) for n in ppi_fields(panels, notes, case)]
        rep.figures["hist"] = [draw(histogram_figure, panels)] if panels else []
        rep.figures["sweeps"] = [
            draw(figure, scores, s, case)
            for s in systems
            for figure in (sweep_figure, sidelobe_figure)
        ]
        rep.sweep_verdicts = {s: v for s in systems if (v := sweep_verdicts(scores, s, case))}
        rep.calibration_rows = calibration_rows(scores, systems, case)
        rep.figures["calibration"] = [
            draw(calibration_figure, s, cal)
            for s in systems
            if (cal := (scores[s].get(case, {}).get("-", {}).get("ZDR") or {}).get("calibration"))
        ]
    hardware = manifest.get("hardware", {})
    hardware_systems = [s for s in systems if s in hardware]
    hardware_figures = [draw(hardware_figure, s, hardware[s]) for s in hardware_systems]
    for rep in cases.values():
        rep.figures = {k: draw.drawn(v) for k, v in rep.figures.items()}
    runs = [
        {"key": k, "kind": v.get("kind", ""), "seconds": v.get("seconds")}
        for k, v in manifest.get("runs", {}).items()
    ]
    return {
        "title": meta.get("title") or manifest.get("study_file", "study"),
        "study_file": manifest.get("study_file", ""),
        "study_text": manifest.get("study_text", ""),
        "reference": meta.get("reference_system", ""),
        "seeds": seeds,
        "systems": systems,
        "cases": list(cases.values()),
        "parts": [(k, PART_LABELS.get(k, k), PART_TEXT[k]) for k in (*PARTS, "bias")],
        "colours": PART_COLOURS,
        "notes": notes,
        "graphs": graphs,
        "run_versions": sorted(versions),
        "version": __version__,
        "runs": runs,
        "total_seconds": sum(r["seconds"] or 0.0 for r in runs),
        "beamwidths": meta.get("beamwidths_deg", {}),
        "hardware_systems": hardware_systems,
        "hardware_rows": hardware_table(hardware, hardware_systems),
        "hardware_figures": draw.drawn(hardware_figures),
        "written": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
    }


def render(context: dict[str, Any]) -> str:
    import jinja2

    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(TEMPLATES)),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    return env.get_template("report.html.j2").render(**context)


def write_report(out: str | Path, drawing: Drawing | None = None) -> Path:
    """Draw and write ``out/report.html`` from a study folder; returns its path. ``drawing``:
    where the figures are drawn (here by default; on a cluster with ``Drawing(client)``)."""
    out = Path(out)
    html = render(build(out, drawing))
    path = out / REPORT
    write_atomic(path, html)
    return path
