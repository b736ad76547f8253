"""The report's figures of the runs' sweeps: each moment's truth, estimate and error side by
side for every system (PPI panels), and truth against estimate (two-dimensional histograms)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .figures import Figure, canvas, panel_grid, panel_row, uri
from .statistics import FIELDS

# A moment's truth-against-estimate histogram: bins over the style's limits.
HIST_BINS = 60


def _limits(sweeps: list[Any], name: str) -> tuple[float, float]:
    """Shared colour limits of a moment: the style's, velocity on the widest Nyquist interval,
    phi_DP on the span of the truth."""
    from ..products.moment_figures import STYLES

    style = STYLES[name]
    if name == "VRADH":
        ny = [
            float(np.nanmax(s["nyquist_velocity"].values))
            for s in sweeps
            if "nyquist_velocity" in s
        ]
        ny = [v for v in ny if math.isfinite(v) and v > 0]
        if ny:
            return -max(ny), max(ny)
    if name == "PHIDP":
        vals = [
            np.asarray(s[f"truth_{name}"].values, float) for s in sweeps if f"truth_{name}" in s
        ]
        vals = [v[np.isfinite(v)] for v in vals]
        allv = np.concatenate(vals) if vals else np.array([])
        if allv.size:
            lo, hi = np.percentile(allv, [1, 99])
            lo, hi = 10 * math.floor(lo / 10), 10 * math.ceil(hi / 10)
            if hi > lo:
                return float(lo), float(hi)
    return style.vmin, style.vmax


def _extent(sweep: Any, x: np.ndarray, y: np.ndarray) -> list[float]:
    has = np.zeros((x.shape[0] - 1, x.shape[1] - 1), bool)
    for v in sweep.data_vars:
        if str(v).startswith("truth_"):
            has |= np.isfinite(np.asarray(sweep[v].values, dtype=np.float64))
    if not has.any():
        return [float(x.min()), float(x.max()), float(y.min()), float(y.max())]
    rows, cols = np.nonzero(has)
    xs = x[rows.min() : rows.max() + 2, cols.min() : cols.max() + 2]
    ys = y[rows.min() : rows.max() + 2, cols.min() : cols.max() + 2]
    return [float(xs.min()), float(xs.max()), float(ys.min()), float(ys.max())]


def ppi_figure(name: str, panels: list[tuple[str, Any]]) -> Figure:
    """Truth beside each system's estimate of one moment, on shared limits."""
    import cmweather  # noqa: F401  (registers the weather-radar colour maps)

    from ..products.moment_figures import STYLES, ppi_mesh

    style = STYLES[name]
    vmin, vmax = _limits([s for _, s in panels], name)
    truth_sweep = panels[0][1]
    cols = [("truth", truth_sweep, f"truth_{name}")] + [(n, s, name) for n, s in panels]
    fig = canvas(3.3 * len(cols) + 0.8, 3.6, layout=None)
    axes, bar = panel_row(fig, len(cols))
    extent = None
    mesh = None
    for ax, (title, sweep, var) in zip(axes, cols, strict=True):
        x, y = ppi_mesh(sweep)
        extent = extent or _extent(truth_sweep, *ppi_mesh(truth_sweep))
        ax.set_facecolor("#ececec")
        if var in sweep:
            data = np.ma.masked_invalid(np.asarray(sweep[var].values, dtype=np.float64))
            mesh = ax.pcolormesh(
                x, y, data, shading="flat", cmap=style.cmap, vmin=vmin, vmax=vmax, rasterized=True
            )
        else:
            ax.text(0.5, 0.5, f"{var}\nnot in the store", ha="center", transform=ax.transAxes)
        # Zoomed to the truth's weather, a km as long east as north (as pasim plot does).
        ax.ignore_existing_data_limits = True
        ax.update_datalim([(extent[0], extent[2]), (extent[1], extent[3])])
        ax.autoscale_view(tight=True)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("km east", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0].set_ylabel("km north", fontsize=8)
    if mesh is not None:
        fig.colorbar(mesh, cax=bar, label=f"{name} ({style.units})")
    else:
        bar.set_visible(False)
    return Figure(
        f"{name}: {style.label}",
        uri(fig),
        f"PPI of {name}: truth and every system's estimate",
        f"Shared limits {vmin:g} to {vmax:g} {style.units}; grey: no data.",
    )


def ppi_fields(panels: list[tuple[str, Any]], notes: list[str], case: str = "") -> list[str]:
    """The moments of a case that get a PPI figure: a moment the truth does not hold (no
    system's store has its ``truth_`` field, e.g. velocity of a reflectivity-only file, ZDR
    of a single-polarisation truth) gets no panels, and a note says so."""
    if not panels:
        return []
    drawn = [n for n in FIELDS if any(f"truth_{n}" in s for _, s in panels)]
    skipped = [n for n in FIELDS if n not in drawn]
    if skipped:
        where = f"case {case}: " if case else ""
        notes.append(
            f"{where}no PPI panels for {', '.join(skipped)}: no run scored them against a "
            "truth (the truth does not hold them, or no system estimates them)"
        )
    return drawn


def histogram_figure(panels: list[tuple[str, Any]]) -> Figure:
    """Truth against estimate on each system's scored gates, one row per moment."""
    from matplotlib.colors import LogNorm

    from ..products.moment_figures import STYLES

    names = [n for n in FIELDS if any(f"error_{n}" in s for _, s in panels)]
    fig = canvas(2.9 * len(panels) + 0.6, 2.6 * len(names), layout=None)
    axes = panel_grid(fig, len(names), len(panels))
    for row, name in zip(axes, names, strict=True):
        lo, hi = _limits([s for _, s in panels], name)
        if name == "RHOHV":
            lo, hi = 0.8, 1.0
        for ax, (system, sweep) in zip(row, panels, strict=True):
            err, truth = sweep.get(f"error_{name}"), sweep.get(f"truth_{name}")
            est = sweep.get(name)
            ax.tick_params(labelsize=7)
            if err is None or truth is None or est is None:
                ax.set_visible(False)
                continue
            e = np.asarray(est.values, dtype=np.float64)
            t = np.asarray(truth.values, dtype=np.float64)[:, : e.shape[1]]
            ok = np.isfinite(np.asarray(err.values, dtype=np.float64)) & np.isfinite(e)
            ok &= np.isfinite(t)
            if ok.sum() > 0:
                ax.hist2d(
                    t[ok],
                    e[ok],
                    bins=HIST_BINS,
                    range=[[lo, hi], [lo, hi]],
                    norm=LogNorm(),
                    cmap="viridis",
                    rasterized=True,
                )
            ax.plot([lo, hi], [lo, hi], color="red", lw=0.8)
            ax.set_xlim(lo, hi)
            ax.set_ylim(lo, hi)
            ax.set_title(f"{system}: {name} ({int(ok.sum()):,} gates)", fontsize=9)
            ax.set_xlabel(f"truth ({STYLES[name].units})", fontsize=8)
        row[0].set_ylabel("estimate", fontsize=8)
    return Figure(
        "Truth against estimate",
        uri(fig),
        "two-dimensional histograms of truth against estimate for every system and moment",
        "Scored gates only, counts on a log scale; the red line is estimate = truth.",
    )
