"""Measured or EM-simulated patterns read from a file: a whole antenna, or an array element.

The file is comma-separated text, one line per direction of a regular grid (every azimuth
with every elevation, in any order), ``#`` lines are comments, and the first other line names
the columns::

    # chamber measurement of ..., 2.8 GHz
    azimuth_deg,elevation_deg,h_co_db,h_co_deg,h_cross_db,h_cross_deg,v_co_db,v_co_deg,v_cross_db,v_cross_deg
    -10.0,-10.0,-32.1,12.0,-61.0,-80.5,-31.9,11.2,-60.2,95.0
    ...

* ``azimuth_deg``, ``elevation_deg``: direction from the antenna's boresight (for an element:
  from its normal, in the frame of its face); azimuth clockwise seen from above.
* For each port (``h``, ``v``) and component (``co``, ``cross``): gain in dBi and phase in
  degrees, on the az/el (Ludwig-2) basis: ``co`` is the H port's horizontal and the V port's
  vertical component, ``cross`` the other one. ``-inf`` is a zero field.

:func:`read_pattern_file` returns a :class:`TabulatedPattern` (read in a block's ``load()``);
its fields are interpolated linearly in real and imaginary part, and are zero outside the grid.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

#: Columns of a pattern file, in the order of ``DualPolField``.
COMPONENTS = ("h_co", "h_cross", "v_co", "v_cross")
COLUMNS = ("azimuth_deg", "elevation_deg", *(f"{c}_{q}" for c in COMPONENTS for q in ("db", "deg")))


@dataclass(frozen=True)
class TabulatedPattern:
    """Complex fields of both ports on a regular (elevation, azimuth) grid.

    Attributes
    ----------
    azimuth_deg, elevation_deg : ndarray
        Strictly increasing grid axes.
    values : ndarray
        Complex voltage gains, shape (4, elevation, azimuth), in the order h_co, h_cross,
        v_co, v_cross; ``|value|^2`` is the gain (linear, over isotropic).
    source : str
        The file read.
    """

    azimuth_deg: NDArray[np.float64]
    elevation_deg: NDArray[np.float64]
    values: NDArray[np.complex128]
    source: str = ""

    @property
    def peak_gain_db(self) -> float:
        """Largest co-polar gain of the H port, dBi."""
        return float(10 * np.log10(np.max(np.abs(self.values[0]) ** 2)))

    def fields(self, az_deg: Any, el_deg: Any, normalise: str = "peak") -> Any:
        """Fields at directions ``(az, el)`` (broadcast), as a ``DualPolField``.

        ``normalise``: ``peak`` divides by the H port's peak co-polar voltage gain, so the
        H pattern peaks at 1; ``broadside`` by its value at (0, 0), as the element models.
        """
        from scipy.interpolate import RegularGridInterpolator

        from .geometry import DualPolField

        az, el = np.broadcast_arrays(np.asarray(az_deg, float), np.asarray(el_deg, float))
        points = np.stack([el.ravel(), az.ravel()], axis=-1)
        grid = (self.elevation_deg, self.azimuth_deg)
        out = []
        for component in self.values:
            f = RegularGridInterpolator(grid, component, bounds_error=False, fill_value=0.0)
            out.append(f(points).reshape(az.shape))
        if normalise == "peak":
            scale = np.max(np.abs(self.values[0]))
        else:
            f = RegularGridInterpolator(grid, self.values[0], bounds_error=False, fill_value=0.0)
            scale = abs(complex(f([[0.0, 0.0]])[0]))
            if scale == 0:
                raise ValueError(f"{self.source}: the H co-polar field is zero at (0, 0)")
        return DualPolField(*(c / scale for c in out))


def read_pattern_file(path: str | Path) -> TabulatedPattern:
    """Read a pattern file (format in the module docstring); errors name the file and line."""
    path = Path(path)
    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read pattern file {path}: {exc}") from None
    rows = [
        (i + 1, line)
        for i, line in enumerate(lines)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not rows:
        raise ValueError(f"pattern file {path} has no header line")
    header = [h.strip() for h in rows[0][1].split(",")]
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise ValueError(
            f"pattern file {path}, line {rows[0][0]}: missing column(s) {', '.join(missing)}; "
            f"expected {','.join(COLUMNS)}"
        )
    index = [header.index(c) for c in COLUMNS]
    data = np.empty((len(rows) - 1, len(COLUMNS)))
    for n, (line_no, line) in enumerate(rows[1:]):
        cells = line.split(",")
        if len(cells) != len(header):
            raise ValueError(
                f"pattern file {path}, line {line_no}: {len(cells)} values, expected {len(header)}"
            )
        try:
            data[n] = [float(cells[i]) for i in index]
        except ValueError:
            raise ValueError(
                f"pattern file {path}, line {line_no}: not a number in {line!r}"
            ) from None
    az_col, el_col = data[:, 0], data[:, 1]
    if not (np.all(np.isfinite(az_col)) and np.all(np.isfinite(el_col))):
        raise ValueError(f"pattern file {path}: angles must be finite")
    az, az_i = np.unique(az_col, return_inverse=True)
    el, el_i = np.unique(el_col, return_inverse=True)
    if az.size < 2 or el.size < 2 or az.size * el.size != data.shape[0]:
        raise ValueError(
            f"pattern file {path}: {data.shape[0]} directions do not form a regular grid of "
            f"{el.size} elevations x {az.size} azimuths (each pair once, at least 2 x 2)"
        )
    seen = np.zeros((el.size, az.size), bool)
    seen[el_i, az_i] = True
    if not seen.all():
        raise ValueError(f"pattern file {path}: some azimuth-elevation pairs are repeated")
    values = np.zeros((4, el.size, az.size), complex)
    for k in range(4):
        gain_db, phase_deg = data[:, 2 + 2 * k], data[:, 3 + 2 * k]
        if np.any(np.isnan(gain_db)) or np.any(gain_db == np.inf):
            raise ValueError(f"pattern file {path}: {COMPONENTS[k]}_db must be finite or -inf")
        phase = np.where(np.isfinite(phase_deg), phase_deg, 0.0)
        values[k, el_i, az_i] = 10 ** (gain_db / 20) * np.exp(1j * np.deg2rad(phase))
    if not np.any(values[0]):
        raise ValueError(f"pattern file {path}: the H co-polar gain is zero everywhere")
    return TabulatedPattern(az, el, values, str(path))


def write_pattern_file(path: str | Path, pattern: TabulatedPattern, comment: str = "") -> None:
    """Write a :class:`TabulatedPattern` in the file format (for tools and tests)."""
    el, az = np.meshgrid(pattern.elevation_deg, pattern.azimuth_deg, indexing="ij")
    cols = [az.ravel(), el.ravel()]
    for component in pattern.values:
        with np.errstate(divide="ignore"):
            cols.append(20 * np.log10(np.abs(component.ravel())))
        cols.append(np.rad2deg(np.angle(component.ravel())))
    lines = [f"# {line}" for line in comment.splitlines()] + [",".join(COLUMNS)]
    lines += [",".join(f"{v:.10g}" for v in row) for row in np.stack(cols, axis=-1)]
    Path(path).write_text("\n".join(lines) + "\n")
