"""What every figure of a study's report shares: the drawing canvas, the PNG data URI the
page embeds, and the figure's record for the template."""

from __future__ import annotations

import base64
from dataclasses import dataclass
from typing import Any


@dataclass
class Figure:
    title: str
    uri: str
    alt: str
    caption: str = ""


def canvas(width: float, height: float) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure as MplFigure

    fig = MplFigure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


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
