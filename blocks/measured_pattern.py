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

from pasim_graph import Block, Chunk, Input, Output, Param

from .antenna import offsets, pattern_dataset, two_way_solid_angle
from .signals import BEAMS, PATTERN, POLARIZATIONS

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

        from .patterns import DualPolField

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


class MeasuredAntenna(Block):
    """A mechanically steered antenna whose pattern is read from a file (measured or simulated).

    The file gives both ports' co- and cross-polar complex gains around the boresight (format
    in ``pasim_blocks.measured_pattern`` and docs/arrays.md). For a beam at elevation el_b
    each grid direction is turned into the antenna's frame (rotated up by el_b) and the table
    is interpolated there; the polarisation basis is taken as the antenna's (its rotation off
    the axis is second order in the offsets). Every beam at one elevation has the same pattern,
    so the boresight calibration is the per-beam one.
    """

    beams = Input(BEAMS, doc="beam geometry")
    pattern = Output(PATTERN, doc="one-way H and V co- and cross-polar patterns per beam")

    path = Param(None, type="path", doc="pattern file (format in docs/arrays.md)")
    gain_db = Param(
        None,
        units="dB",
        min=-20.0,
        max=80.0,
        optional=True,
        doc="peak gain (unset: the file's largest H co-polar gain)",
    )
    support_deg = Param(
        10.0, units="deg", min=0.5, max=45.0, doc="half-width of the pattern grid around the axis"
    )
    grid_step_deg = Param(0.05, units="deg", min=0.001, max=1.0, doc="pattern grid step")

    transient = ("_memo",)

    @classmethod
    def warm_up(cls) -> None:
        import scipy.interpolate  # noqa: F401

    def setup(self) -> None:
        self.d_az = offsets(self.p["support_deg"], self.p["grid_step_deg"])
        self.d_el = self.d_az.copy()
        self._memo: dict[float, tuple[np.ndarray, np.ndarray]] | None = {}

    def load(self) -> TabulatedPattern:
        return read_pattern_file(self.p["path"])

    def broadside(self) -> tuple[float, float]:
        return 0.0, 0.0

    def fields_at(
        self,
        steer_az_deg: float,
        steer_el_deg: float,
        az_deg: Any,
        el_deg: Any,
        seed: int = 0,
        resource: Any = None,
    ) -> Any:
        """Fields at absolute directions for the antenna pointed at (az, el)."""
        el0 = np.deg2rad(steer_el_deg)
        el = np.deg2rad(np.asarray(el_deg, float))
        d_az = np.deg2rad(np.asarray(az_deg, float) - steer_az_deg)
        x, y, z = np.cos(el) * np.sin(d_az), np.cos(el) * np.cos(d_az), np.sin(el)
        # Into the antenna frame: rotate about the horizontal axis by -el0.
        y_a = y * np.cos(el0) + z * np.sin(el0)
        z_a = -y * np.sin(el0) + z * np.cos(el0)
        az_a = np.rad2deg(np.arctan2(x, y_a))
        el_a = np.rad2deg(np.arcsin(np.clip(z_a, -1.0, 1.0)))
        return resource.fields(az_a, el_a, normalise="peak")

    def pattern_gain_db(self, resource: Any = None) -> float:
        return self.gain(resource)

    def gain(self, resource: TabulatedPattern) -> float:
        return float(resource.peak_gain_db if self.p["gain_db"] is None else self.p["gain_db"])

    def _grid(self, el_deg: float, resource: TabulatedPattern) -> tuple[np.ndarray, np.ndarray]:
        if self._memo is None:
            self._memo = {}
        if el_deg not in self._memo:
            f = self.fields_at(
                0.0, el_deg, self.d_az[None, :], el_deg + self.d_el[:, None], 0, resource
            )
            shape = (self.d_el.size, self.d_az.size)
            co = np.stack([np.broadcast_to(f.h_co, shape), np.broadcast_to(f.v_co, shape)])
            cross = np.stack([np.broadcast_to(f.h_cross, shape), np.broadcast_to(f.v_cross, shape)])
            self._memo[el_deg] = (co, cross)
        return self._memo[el_deg]

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        table = chunk.resource
        reference, _ = self._grid(0.0, table)
        ref_power = np.abs(reference) ** 2
        omega = {
            p: two_way_solid_angle(ref_power[i], self.d_az, self.d_el, 0.0)
            for i, p in enumerate(POLARIZATIONS)
        }
        grids = [self._grid(float(e), table) for e in inputs["beams"]["elevation"].values]
        co = np.stack([g[0] for g in grids])
        cross = np.stack([g[1] for g in grids])
        ds = pattern_dataset(
            (co.real**2 + co.imag**2).astype(np.float32),
            self.d_az,
            self.d_el,
            self.gain(table),
            omega,
            co_polar=co,
            cross_polar=cross,
            antenna=f"measured ({Path(table.source).name})",
        )
        return {"pattern": ds}
