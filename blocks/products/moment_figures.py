"""Pictures of a run: truth, estimate and error of each moment as PPIs.

``pasim plot STORE`` draws one row per moment, truth | estimate | error (estimate minus
truth), in km east and north of the radar, with the usual weather-radar colour maps
(cmweather's ChaseSpectral for reflectivity, balance for velocity and for every error, ...)
and fixed limits per moment, so that two runs are drawn on the same scales. The studio shows
the same pictures, one moment at a time (:func:`run_figures`, registered in the
``pasim_graph.figures`` entry-point group so the engine's studio never imports this package).

Only matplotlib's object API is used (``Figure`` with the Agg canvas, never ``pyplot``): no
global state, so the studio can draw from several threads and no display is ever needed.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph.fm301 import BEAM_DIMENSIONS, SWEEP_MODE_RHI
from pasim_graph.fm301 import MOMENT_FIELDS as MOMENTS
from pasim_graph.outputs import write_atomic
from pasim_graph.store import NotAStoreError, open_sweep

__all__ = ["NotAStoreError", "open_sweep"]  # re-exported: the plot reads a run with them


@dataclass(frozen=True)
class Style:
    """How one moment is drawn: name, units, limits and colour maps of value and error."""

    label: str
    units: str
    vmin: float
    vmax: float
    cmap: str
    error_limit: float  # errors are drawn on [-limit, +limit]
    error_cmap: str = "balance"


STYLES: dict[str, Style] = {
    "DBZH": Style("reflectivity", "dBZ", -10.0, 70.0, "ChaseSpectral", 5.0),
    "ZDR": Style("differential reflectivity", "dB", -2.0, 6.0, "RefDiff", 1.0),
    "RHOHV": Style("correlation coefficient", "1", 0.7, 1.05, "HomeyerRainbow", 0.05),
    "PHIDP": Style("differential phase", "deg", 0.0, 360.0, "Wild25", 20.0),
    # VRADH limits are the run's Nyquist interval (see _limits); these are the fallback.
    "VRADH": Style("radial velocity", "m/s", -30.0, 30.0, "balance", 5.0),
    "WRADH": Style("spectrum width", "m/s", 0.0, 8.0, "NWS_SPW", 3.0),
}


def available(sweep: xr.Dataset, fields: list[str] | None = None) -> tuple[list[str], list[str]]:
    """The moments that can be drawn, and a note for each asked-for one that cannot or that
    is drawn without a truth."""
    from pasim_graph.scores import no_truth

    asked = list(fields) if fields else list(MOMENTS)
    drawn, notes = [], []
    missing = no_truth(sweep)
    for name in asked:
        if name not in STYLES:
            notes.append(f"{name}: not a moment this plot knows ({', '.join(MOMENTS)}); skipped")
        elif name not in sweep and f"truth_{name}" not in sweep:
            notes.append(f"{name}: neither {name} nor truth_{name} is in the store; skipped")
        else:
            drawn.append(name)
            if name in missing:
                notes.append(f"{name}: the truth holds no {name}; drawn as estimate only, no truth")
    return drawn, notes


def lacks_truth(sweep: xr.Dataset, name: str) -> bool:
    """The run estimated ``name`` but its truth holds none (the scorer names it so)."""
    from pasim_graph.scores import no_truth

    return name in no_truth(sweep)


def _edges(centres: np.ndarray) -> np.ndarray:
    """Cell edges halfway between centres, the ends extended by half a step."""
    c = np.asarray(centres, dtype=np.float64)
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = (c[1:] + c[:-1]) / 2
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def ppi_mesh(sweep: xr.Dataset) -> tuple[np.ndarray, np.ndarray]:
    """x (east) and y (north) of the gate corners in km, on the ground.

    Ground distance is ``range * cos(elevation)``: at the low elevations of a PPI this differs
    from a 4/3-earth beam path by well under a gate at the ranges of a Level-II sweep.
    """
    beam_dim = next(d for d in BEAM_DIMENSIONS if d in sweep.dims)
    az = np.unwrap(np.deg2rad(np.asarray(sweep["azimuth"].values, dtype=np.float64)))
    rng = np.asarray(sweep["range"].values, dtype=np.float64) / 1000.0
    elev = float(np.nanmean(sweep["elevation"].values)) if "elevation" in sweep else 0.0
    if beam_dim != "azimuth":
        raise ValueError(f"a PPI needs beams along azimuth, this sweep runs along {beam_dim}")
    a, r = np.meshgrid(_edges(az), _edges(rng) * math.cos(math.radians(elev)), indexing="ij")
    return r * np.sin(a), r * np.cos(a)


def is_rhi(sweep: xr.Dataset) -> bool:
    """The sweep is an RHI (FM-301 ``sweep_mode``), drawn as range against height."""
    return "sweep_mode" in sweep and str(sweep["sweep_mode"].values) == SWEEP_MODE_RHI


def rhi_mesh(sweep: xr.Dataset) -> tuple[np.ndarray, np.ndarray]:
    """Ground distance and height above the radar (km) of the gate corners of an RHI, along
    the 4/3-earth beam path (beams along ``elevation``)."""
    from ..scans.beam_geometry import beam_height_m, ground_range_m

    if "elevation" not in sweep.dims:
        raise ValueError("an RHI needs beams along elevation")
    el = _edges(np.asarray(sweep["elevation"].values, dtype=np.float64))
    rng = _edges(np.asarray(sweep["range"].values, dtype=np.float64))
    e, r = np.meshgrid(el, rng, indexing="ij")
    return ground_range_m(r, e) / 1000.0, beam_height_m(r, e) / 1000.0


def mesh(sweep: xr.Dataset) -> tuple[np.ndarray, np.ndarray]:
    """Gate corners of a sweep in km: range-height for an RHI, east-north for the rest."""
    return rhi_mesh(sweep) if is_rhi(sweep) else ppi_mesh(sweep)


def _limits(sweep: xr.Dataset, name: str) -> tuple[float, float]:
    style = STYLES[name]
    if name == "VRADH":
        if "nyquist_velocity" in sweep:
            v = float(np.nanmax(sweep["nyquist_velocity"].values))
            if math.isfinite(v) and v > 0:
                return -v, v
        period = sweep.get("error_VRADH", xr.DataArray()).attrs.get("period")
        if period:
            return -float(period) / 2, float(period) / 2
    return style.vmin, style.vmax


def _extent(
    sweep: xr.Dataset, names: list[str], x: np.ndarray, y: np.ndarray, exact: bool = False
) -> list[float]:
    """The box around the weather: gates where the truth has data (a margin of 5 %).

    An estimate exists at every gate, noise included, so it would always ask for the whole
    sector; it decides only when the store holds no truth.
    """
    has = np.zeros((x.shape[0] - 1, x.shape[1] - 1), bool)
    for n in names:
        truth = [v for v in (f"truth_{n}", f"error_{n}") if v in sweep]
        for v in truth or ([n] if n in sweep else []):
            has |= np.isfinite(np.asarray(sweep[v].values, dtype=np.float64))
    if not has.any():
        xs, ys = x, y
    elif exact:
        # The corners of the gates with data themselves (an RHI: the index box's corners
        # would reach the top beam's far gates, tens of km up).
        rows, cols = np.nonzero(has)
        xs = np.concatenate([x[rows + i, cols + j] for i in (0, 1) for j in (0, 1)])
        ys = np.concatenate([y[rows + i, cols + j] for i in (0, 1) for j in (0, 1)])
    else:
        rows, cols = np.nonzero(has)
        r0, r1 = rows.min(), rows.max() + 1
        c0, c1 = cols.min(), cols.max() + 1
        xs, ys = x[r0 : r1 + 1, c0 : c1 + 1], y[r0 : r1 + 1, c0 : c1 + 1]
    x0, x1, y0, y1 = float(xs.min()), float(xs.max()), float(ys.min()), float(ys.max())
    pad = 0.05 * max(x1 - x0, y1 - y0, 1.0)
    return [x0 - pad, x1 + pad, y0 - pad, y1 + pad]


def _panel(
    ax: Any, fig: Any, sweep: xr.Dataset, var: str, title: str, bar: Any = None, **kw: Any
) -> None:
    import cmweather  # noqa: F401  (registers the weather-radar colour maps with matplotlib)

    x, y = kw.pop("mesh")
    units = kw.pop("units")
    absent = kw.pop("absent", f"{var}\nnot in the store")
    if var not in sweep:
        ax.text(
            0.5,
            0.5,
            absent,
            ha="center",
            va="center",
            transform=ax.transAxes,
            color="#666666",
        )
        ax.set_title(title)
        return
    data = np.ma.masked_invalid(np.asarray(sweep[var].values, dtype=np.float64))
    ax.set_facecolor("#ececec")  # no data is grey, not the white of a zero on "balance"
    mesh = ax.pcolormesh(x, y, data, shading="flat", rasterized=True, **kw)
    if bar is not None:
        bar.set_visible(True)
        fig.colorbar(mesh, cax=bar, label=units)
    else:
        fig.colorbar(mesh, ax=ax, label=units)
    ax.set_title(title)


def moment_row(
    fig: Any,
    axes: Any,
    sweep: xr.Dataset,
    name: str,
    scores: dict[str, dict[str, Any]] | None = None,
    bars: Any = None,
) -> None:
    """Draw truth | estimate | error of one moment on three axes of ``fig``, each panel's
    colour bar on its axes in ``bars`` (placed by :func:`_grid`) or taken from the panel's."""
    bars = [None] * 3 if bars is None else bars
    style = STYLES[name]
    x, y = mesh(sweep)
    rhi = is_rhi(sweep)
    vmin, vmax = _limits(sweep, name)
    extent = _extent(sweep, [name], x, y, exact=rhi)
    lim = style.error_limit
    common: dict[str, Any] = {"mesh": (x, y)}
    # A moment the truth does not hold: its row says so, not an empty truth and error.
    bare = lacks_truth(sweep, name)
    if bare:
        common["absent"] = f"no truth:\nthe truth holds no {name}"
    mark = " (no truth)" if bare else ""
    _panel(
        axes[0],
        fig,
        sweep,
        f"truth_{name}",
        f"truth {name}{mark}",
        cmap=style.cmap,
        vmin=vmin,
        vmax=vmax,
        units=style.units,
        bar=bars[0],
        **common,
    )
    _panel(
        axes[1],
        fig,
        sweep,
        name,
        f"estimate {name}{mark}",
        cmap=style.cmap,
        vmin=vmin,
        vmax=vmax,
        units=style.units,
        bar=bars[1],
        **common,
    )
    _panel(
        axes[2],
        fig,
        sweep,
        f"error_{name}",
        f"error {name} (no truth: not scored)" if bare else f"error {name} (estimate - truth)",
        cmap=style.error_cmap,
        vmin=-lim,
        vmax=lim,
        units=style.units,
        bar=bars[2],
        **common,
    )
    s = (scores or {}).get(name)
    if s and s.get("count"):
        verdict = "pass" if s["pass"] else "fail"
        axes[2].text(
            0.02,
            0.02,
            f"bias {s['bias']:.3g}  std {s['std']:.3g}\n"
            f"required {s['requirement_bias']:g} / {s['requirement_std']:g}: {verdict}",
            transform=axes[2].transAxes,
            fontsize=8,
            va="bottom",
            bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none"},
        )
    for ax in axes:
        # Zoom to the gates with data; the axes keep their box and widen the shorter side so
        # that a km is as long east as north (fixed limits on both would fight the aspect).
        ax.ignore_existing_data_limits = True
        ax.update_datalim([(extent[0], extent[2]), (extent[1], extent[3])])
        ax.autoscale_view(tight=True)
        if rhi:
            # Heights are tens of times shorter than ranges: the height axis is stretched.
            ax.set_ylim(0.0, extent[3])
            ax.set_xlabel("km along the ground")
        else:
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_xlabel("km east of the radar")
    if rhi:
        az = float(sweep["sweep_fixed_angle"].values) if "sweep_fixed_angle" in sweep else 0.0
        axes[0].set_ylabel(f"{name}{mark}\nkm above the radar (4/3 earth), azimuth {az:.1f} deg")
    else:
        axes[0].set_ylabel(f"{name}{mark}\nkm north of the radar")


def _figure(rows: int) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(15.0, 4.2 * rows))
    FigureCanvasAgg(fig)
    return fig


#: Where a store figure's panels and colour bars go, in inches: room for the two-line y
#: labels, the titles and tick labels at matplotlib's default sizes, each bar with its tick
#: labels and units right of its panel. Fixed rather than worked out by constrained layout,
#: which measured every label three times and took half of a figure's drawing time.
MARGINS = {
    "left": 0.9, "right": 0.1, "top": 0.4, "title": 0.35, "bottom": 0.55,
    "gap": 0.35, "row_gap": 0.9, "pad": 0.12, "bar": 0.15, "bar_labels": 0.75,
}  # fmt: skip


def _grid(fig: Any, rows: int, title: bool) -> tuple[Any, Any]:
    """``rows`` x 3 panel axes, then ``rows`` x 3 colour-bar axes (hidden until a panel draws
    a mesh), placed by :data:`MARGINS`."""
    m = MARGINS
    w, h = fig.get_size_inches()
    top = m["top"] + (m["title"] if title else 0.0)
    slot = (w - m["left"] - m["right"] - 2 * m["gap"]) / 3
    width = slot - m["pad"] - m["bar"] - m["bar_labels"]
    height = (h - top - m["bottom"] - (rows - 1) * m["row_gap"]) / rows
    # Each panel's lower left corner (inches), row by row; the panels are added before the
    # bars, so that a figure's first axes are its panels.
    corners = [
        (m["left"] + c * (slot + m["gap"]), h - top - r * (height + m["row_gap"]) - height)
        for r in range(rows)
        for c in range(3)
    ]
    axes = [fig.add_axes((x / w, y / h, width / w, height / h)) for x, y in corners]
    bars = [
        fig.add_axes(((x + width + m["pad"]) / w, y / h, m["bar"] / w, height / h))
        for x, y in corners
    ]
    for bar in bars:
        bar.set_visible(False)
    return np.array(axes, object).reshape(rows, 3), np.array(bars, object).reshape(rows, 3)


def store_figure(
    sweep: xr.Dataset, names: list[str], title: str = "", scores: dict | None = None
) -> Any:
    """One figure, one row per moment: truth | estimate | error.

    Parameters
    ----------
    sweep : xarray.Dataset
        A stored sweep (``azimuth`` x ``range``) with ``<moment>``, ``truth_<moment>`` and
        ``error_<moment>`` as far as the run wrote them.
    names : list of str
        Moments to draw (keys of :data:`STYLES`).
    title : str
        Figure title.
    scores : dict, optional
        ``store.summarize`` of the sweep: bias, std and verdict go on the error panels.

    Returns
    -------
    matplotlib.figure.Figure
        A figure on the Agg canvas (no pyplot, no display).
    """
    fig = _figure(len(names))
    axes, bars = _grid(fig, len(names), bool(title))
    for row, bar_row, name in zip(axes, bars, names, strict=True):
        moment_row(fig, row, sweep, name, scores, bar_row)
    if title:
        fig.suptitle(title, y=1 - 0.12 / fig.get_size_inches()[1], va="top")
    return fig


def moment_figure(sweep: xr.Dataset, name: str, scores: dict | None = None) -> Any:
    """The row of one moment as its own figure (the studio shows one per moment)."""
    return store_figure(sweep, [name], scores=scores)


def png_bytes(fig: Any, dpi: int = 90) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def title_of(path: str | Path, attrs: dict[str, Any], sweep: xr.Dataset) -> str:
    if is_rhi(sweep):
        steps = np.asarray(sweep["elevation"].values)
        at = float(np.asarray(sweep["azimuth"].values)[0])
        sector = f"RHI at azimuth {at:.1f} deg, elevation {steps.min():.1f}-{steps.max():.1f} deg, "
        graph = attrs.get("graph_file", "")
        return f"{Path(path).name}: {graph}, {sector}seed {attrs.get('seed', '?')}"
    az = np.asarray(sweep["azimuth"].values) if "azimuth" in sweep else np.array([])
    el = np.asarray(sweep["elevation"].values) if "elevation" in sweep else np.array([])
    sector = f"azimuth {az.min():.1f}-{az.max():.1f} deg, " if az.size else ""
    if el.size and int(np.asarray(sweep.get("sweep_number", 0)).item()) > 0:
        sector += f"elevation {float(np.nanmean(el)):.1f} deg, "
    graph = attrs.get("graph_file", "")
    return f"{Path(path).name}: {graph}, {sector}seed {attrs.get('seed', '?')}"


def plot_store(
    path: str | Path,
    out: str | Path,
    fields: list[str] | None = None,
    dpi: int = 90,
    sweep_index: int = 0,
) -> list[str]:
    """Draw a run to a PNG: one row per moment, truth | estimate | error.

    Parameters
    ----------
    path : path
        A finished run's store (``pasim run --out``).
    out : path
        The PNG to write.
    fields : list of str, optional
        Moments to draw, in this order; default every moment the store has.
    dpi : int
        Resolution of the PNG.
    sweep_index : int
        Which sweep of a volume (``sweep_N``) to draw.

    Returns
    -------
    list of str
        A note for each asked-for field that was skipped, and why.

    Raises
    ------
    NotAStoreError
        ``path`` is not a finished PASIM-graph run.
    ValueError
        None of the fields can be drawn.
    """
    from pasim_graph.fm301 import sweep_names
    from pasim_graph.store import open_finished, root_attrs, summarize, sweep_of

    tree = open_finished(path)
    sweep, attrs = sweep_of(tree, path, sweep_index), root_attrs(tree)
    names, notes = available(sweep, fields)
    if not names:
        raise ValueError(f"{path}: none of the fields can be drawn ({'; '.join(notes)})")
    title = title_of(path, attrs, sweep)
    count = len(sweep_names(tree))
    if count > 1:
        # A volume: say which of its sweeps this is, in the picture and to the user.
        title += f", sweep {sweep_index} of {count}"
        notes.append(f"drew sweep {sweep_index} of the volume's {count} (--sweep N for another)")
    fig = store_figure(sweep, names, title, summarize(sweep))
    write_atomic(out, png_bytes(fig, dpi))
    return notes


def run_figures(
    sweep: xr.Dataset, scores: dict | None = None, dpi: int = 80
) -> tuple[list[tuple[str, bytes]], list[str]]:
    """One PNG per moment the sweep can show (truth | estimate | error), and notes on the rest.

    The studio's run pictures: the engine finds this function through the
    ``pasim_graph.figures`` entry-point group (``moments``) and calls it on a finished store.
    """
    names, notes = available(sweep)
    return [(n, png_bytes(moment_figure(sweep, n, scores), dpi=dpi)) for n in names], notes
