"""What every figure of a study's report shares: the drawing canvas, the PNG data URI the
page embeds, the figure's record for the template, and where figures are drawn (here, or as
tasks on the study's cluster: :class:`Drawing`)."""

from __future__ import annotations

import base64
import os
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from .measuring import timed


@dataclass
class Figure:
    title: str
    uri: str
    alt: str
    caption: str = ""


def canvas(
    width: float, height: float, layout: Literal["constrained"] | None = "constrained"
) -> Any:
    """A figure of ``width`` x ``height`` inches; ``layout=None`` for a figure that places
    its axes itself (:func:`panel_row`)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure as MplFigure

    fig = MplFigure(figsize=(width, height), layout=layout)
    FigureCanvasAgg(fig)
    return fig


#: The margins of a row of panels with a colour bar at its right, in inches: room for the
#: report's tick labels (7 pt), axis labels (8 pt) and titles (10 pt), and for the bar, its
#: tick labels and its label. Fixed, not worked out by matplotlib's constrained layout, which
#: measured every label three times and took half of each such figure's drawing time.
ROW_MARGINS = {"left": 0.5, "right": 0.95, "bottom": 0.45, "top": 0.28, "gap": 0.4}


#: The margins of a grid of panels, each with its title and x label, without a colour bar.
GRID_MARGINS = {
    "left": 0.55,
    "right": 0.15,
    "bottom": 0.42,
    "top": 0.26,
    "gap": 0.45,
    "row_gap": 0.72,
}


def panel_grid(fig: Any, rows: int, cols: int) -> Any:
    """A ``rows`` x ``cols`` array of axes placed by :data:`GRID_MARGINS` on a figure made
    with ``canvas(..., layout=None)``."""
    m = GRID_MARGINS
    w, h = fig.get_size_inches()
    width = (w - m["left"] - m["right"] - m["gap"] * (cols - 1)) / cols
    height = (h - m["bottom"] - m["top"] - m["row_gap"] * (rows - 1)) / rows
    return fig.subplots(
        rows,
        cols,
        squeeze=False,
        gridspec_kw={
            "left": m["left"] / w,
            "right": 1 - m["right"] / w,
            "bottom": m["bottom"] / h,
            "top": 1 - m["top"] / h,
            "wspace": m["gap"] / width,
            "hspace": m["row_gap"] / height,
        },
    )


def panel_row(fig: Any, n: int) -> tuple[list[Any], Any]:
    """``n`` axes side by side and the axes of their colour bar, placed by :data:`ROW_MARGINS`
    on a figure made with ``canvas(..., layout=None)``."""
    m = ROW_MARGINS
    w, h = fig.get_size_inches()
    width = (w - m["left"] - m["right"] - m["gap"] * (n - 1)) / n
    bottom, top = m["bottom"] / h, 1 - m["top"] / h
    axes = fig.subplots(
        1,
        n,
        squeeze=False,
        gridspec_kw={
            "left": m["left"] / w,
            "right": 1 - m["right"] / w,
            "bottom": bottom,
            "top": top,
            "wspace": m["gap"] / width,
        },
    )[0]
    # The bar: 0.14 in wide, 0.2 in right of the panels, nine tenths of their height.
    span = top - bottom
    bar = fig.add_axes((1 - (m["right"] - 0.2) / w, bottom + 0.05 * span, 0.14 / w, 0.9 * span))
    return list(axes), bar


def uri(fig: Any, dpi: int = 72) -> str:
    from ..products.moment_figures import png_bytes

    return "data:image/png;base64," + base64.b64encode(png_bytes(fig, dpi)).decode("ascii")


def point_value(point: str) -> dict[str, Any]:
    """``"a.b=3,c.d=x"`` -> {"a.b": 3.0, "c.d": "x"} (numbers as floats)."""
    out: dict[str, Any] = {}
    if point == "-":
        return out
    for part in point.split(","):
        key, _, value = part.partition("=")
        try:
            out[key] = float(value)
        except ValueError:
            out[key] = value
    return out


#: matplotlib is not thread-safe: a worker running several tasks at once in threads draws
#: one figure at a time (a LocalCluster's workers have one thread each).
_ONE_AT_A_TIME = threading.Lock()


def _drawn_alone(draw: Callable[..., Figure | None], *args: Any) -> tuple[Figure | None, float]:
    """``draw(*args)`` and the seconds it took, one figure at a time in this process."""
    with _ONE_AT_A_TIME:
        return timed(draw, *args)


class Drawing:
    """Where the report's figures are drawn: here, one after another, or with ``client`` as
    tasks on the study's cluster, all at once (rendering them is most of a report's time:
    6 s of the paper study's, one after another). :meth:`drawn` gives a list back drawn,
    in its order, without the figures that had nothing to show (None)."""

    def __init__(self, client: Any = None):
        self.client = client
        #: Figures drawn, and the seconds they took where they were drawn (all together).
        self.count, self.seconds = 0, 0.0
        # Keys of this report's own: another study's report may draw on the same cluster.
        self._token, self._asked = os.urandom(6).hex(), 0

    def __call__(self, draw: Callable[..., Figure | None], *args: Any) -> Any:
        self._asked += 1
        if self.client is None:
            figure, seconds = _drawn_alone(draw, *args)
            self.seconds += seconds
            return figure
        key = f"pasim-figure-{draw.__name__}-{self._token}-{self._asked}"
        return self.client.submit(_drawn_alone, draw, *args, key=key)

    def drawn(self, figures: list[Any]) -> list[Figure]:
        if self.client is not None:
            timed = self.client.gather(figures)
            self.seconds += sum(seconds for _, seconds in timed)
            figures = [figure for figure, _ in timed]
        drawn = [f for f in figures if f is not None]
        self.count += len(drawn)
        return drawn
