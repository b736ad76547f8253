"""Where an array's elements are and which way they face: the one description every array of
:mod:`.conformal` is computed from.

A :class:`Layout` holds the elements as *columns* sharing one *stack*: element ``(c, m)`` sits
at ``column_position[c] + stack_m[m] * axis`` and faces along ``normal[c]``. A planar face is
``n_x`` columns of ``n_y`` elements up the face; a cylinder is a ring of vertical columns; a
ring, a line or any set of elements is a stack of one. The split is only a way of computing
(the stack's phase factor is shared by every column); every element is still summed on its
own position. Positions are metres in the array's east-north-up frame, normals unit vectors.
Each element also belongs to a T/R channel (``channel``, shape columns x stack): one module per
element, per subarray or per column.

Builders: :func:`linear_layout`, :func:`ring_layout`, :func:`lattice_layout`, and
:func:`read_element_file` / :func:`layout_from_elements` for a file of element positions and
outward normals (format in :data:`FILE_COLUMNS` and docs/arrays.md).
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

#: Columns of an element file: position (m, east-north-up), outward normal, and optionally the
#: T/R channel each element belongs to.
FILE_COLUMNS = ("x_m", "y_m", "z_m", "normal_x", "normal_y", "normal_z")
CHANNEL_COLUMN = "channel"
#: Positions equal to this (m) are the same position when a file is grouped into columns.
_TOLERANCE_M = 1e-6


@dataclass(frozen=True)
class Layout:
    """Element positions, normals and channels of an array (see the module docstring).

    Attributes
    ----------
    column_position : ndarray
        (columns, 3) centre of each column, m, east-north-up.
    normal : ndarray
        (columns, 3) outward unit normal of each column's elements.
    axis : ndarray
        (3,) unit vector along which every column's stack runs.
    stack_m : ndarray
        (stack,) offsets of a column's elements along ``axis`` from its centre, m (mean 0).
    channel : ndarray
        (columns, stack) integer T/R channel of each element.
    """

    column_position: NDArray[np.float64]
    normal: NDArray[np.float64]
    axis: NDArray[np.float64]
    stack_m: NDArray[np.float64]
    channel: NDArray[np.int64]

    @property
    def n_channels(self) -> int:
        return int(self.channel.max()) + 1

    @property
    def normal_azimuth_deg(self) -> NDArray[np.float64]:
        return np.rad2deg(np.arctan2(self.normal[:, 0], self.normal[:, 1])) % 360.0

    @property
    def normal_tilt_deg(self) -> NDArray[np.float64]:
        return np.rad2deg(np.arcsin(np.clip(self.normal[:, 2], -1.0, 1.0)))

    def positions(self) -> NDArray[np.float64]:
        """Every element's position, (columns, stack, 3)."""
        return self.column_position[:, None, :] + self.stack_m[None, :, None] * self.axis


def face_axes(azimuth_deg: float, tilt_deg: float) -> tuple[NDArray, NDArray, NDArray]:
    """Across (horizontal, towards increasing azimuth), up-the-face and normal unit vectors of
    a face whose normal points at ``azimuth_deg``, tilted up ``tilt_deg`` (the frame of
    :func:`pasim_blocks.antennas.geometry.face_geometry`)."""
    a, t = np.deg2rad(azimuth_deg), np.deg2rad(tilt_deg)
    across = np.array([np.cos(a), -np.sin(a), 0.0])
    normal = np.array([np.cos(t) * np.sin(a), np.cos(t) * np.cos(a), np.sin(t)])
    return across, np.cross(across, normal), normal


def _centred(n: int, spacing: float) -> NDArray[np.float64]:
    return (np.arange(n, dtype=np.float64) - (n - 1) / 2.0) * spacing


def _subarrays(n: int, size: int) -> NDArray[np.int64]:
    return np.arange(n, dtype=np.int64) // size


def linear_layout(
    n: int, spacing_m: float, face_azimuth_deg: float, face_tilt_deg: float, subarray: int = 1
) -> Layout:
    """``n`` elements ``spacing_m`` apart across a face, ``subarray`` consecutive elements per
    channel."""
    across, up, normal = face_axes(face_azimuth_deg, face_tilt_deg)
    return Layout(
        column_position=np.outer(_centred(n, spacing_m), across),
        normal=np.tile(normal, (n, 1)),
        axis=up,
        stack_m=np.zeros(1),
        channel=_subarrays(n, subarray)[:, None],
    )


def lattice_layout(
    n_x: int,
    n_y: int,
    spacing_x_m: float,
    spacing_y_m: float,
    face_azimuth_deg: float,
    face_tilt_deg: float,
    lattice: str = "rectangular",
    subarray_x: int = 1,
    subarray_y: int = 1,
) -> Layout:
    """A planar face of ``n_x`` columns of ``n_y`` elements, rectangular or triangular (every
    other column raised half a spacing), ``subarray_x`` by ``subarray_y`` elements per channel
    numbered column by column (channel ``i_x * (n_y / subarray_y) + i_y``, the order of the
    planar array's channel grid)."""
    across, up, normal = face_axes(face_azimuth_deg, face_tilt_deg)
    x = _centred(n_x, spacing_x_m)
    raise_m = np.zeros(n_x)
    if lattice == "triangular":
        raise_m = (np.arange(n_x) % 2 - 0.5) * spacing_y_m / 2
    elif lattice != "rectangular":
        raise ValueError(f"unknown lattice {lattice!r}; known: rectangular, triangular")
    rows = n_y // subarray_y
    channel = _subarrays(n_x, subarray_x)[:, None] * rows + _subarrays(n_y, subarray_y)[None, :]
    return Layout(
        column_position=np.outer(x, across) + np.outer(raise_m, up),
        normal=np.tile(normal, (n_x, 1)),
        axis=up,
        stack_m=_centred(n_y, spacing_y_m),
        channel=channel,
    )


def ring_layout(
    n: int,
    radius_m: float,
    arc_deg: float,
    centre_azimuth_deg: float,
    stack: int = 1,
    spacing_z_m: float = 0.0,
    subarray: int = 1,
) -> Layout:
    """``n`` columns at the centres of ``n`` equal cells of an arc of ``arc_deg`` (360: a full
    ring) centred on ``centre_azimuth_deg``, each facing out along its radius, of ``stack``
    elements ``spacing_z_m`` apart up (1: a ring; more: a cylinder or a cylindrical arc); one
    channel per ``subarray`` consecutive columns (the whole column behind one module)."""
    az = np.deg2rad(centre_azimuth_deg + _centred(n, arc_deg / n))
    normal = np.stack([np.sin(az), np.cos(az), np.zeros(n)], axis=-1)
    return Layout(
        column_position=radius_m * normal,
        normal=normal,
        axis=np.array([0.0, 0.0, 1.0]),
        stack_m=_centred(stack, spacing_z_m),
        channel=np.repeat(_subarrays(n, subarray)[:, None], stack, axis=1),
    )


# ---- files ------------------------------------------------------------------------------------


def read_element_file(path: str | Path) -> tuple[NDArray, NDArray, NDArray]:
    """Positions (n, 3), unit normals (n, 3) and channels (n,) of the elements in ``path``.

    Comma-separated text, ``#`` lines are comments, the first other line is the header naming
    :data:`FILE_COLUMNS` (any order) and optionally ``channel``; one element a line. Without
    a ``channel`` column each element has its own T/R channel. Errors name the file and line.
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"element file {path}: cannot be read ({exc})") from None
    rows = [
        (i + 1, line) for i, line in enumerate(lines) if line.strip() and line.lstrip()[0] != "#"
    ]
    if not rows:
        raise ValueError(f"element file {path}: empty; expected a header {','.join(FILE_COLUMNS)}")
    header = [h.strip() for h in rows[0][1].split(",")]
    missing = [c for c in FILE_COLUMNS if c not in header]
    if missing:
        raise ValueError(
            f"element file {path}, line {rows[0][0]}: missing column(s) {', '.join(missing)}; "
            f"expected {','.join(FILE_COLUMNS)} and optionally {CHANNEL_COLUMN}"
        )
    if len(rows) == 1:
        raise ValueError(f"element file {path}: holds a header and no element")
    wanted = [*FILE_COLUMNS, *([CHANNEL_COLUMN] if CHANNEL_COLUMN in header else [])]
    index = [header.index(c) for c in wanted]
    data: NDArray[np.float64] | None = None
    try:  # the fast path; a line it cannot read is found and named by the loop below
        import pandas as pd

        text = io.StringIO("\n".join(line for _, line in rows[1:]))
        table = pd.read_csv(text, header=None, dtype=np.float64, engine="c").to_numpy()
        if table.shape == (len(rows) - 1, len(header)):
            data = table[:, index]
    except (ValueError, pd.errors.ParserError):
        pass
    if data is None or not np.all(np.isfinite(data)):
        data = _read_lines(path, rows[1:], len(header), index)
    positions, normals = data[:, 0:3], data[:, 3:6]
    length = np.linalg.norm(normals, axis=1)
    bad = np.flatnonzero(np.abs(length - 1.0) > 1e-3)
    if bad.size:
        raise ValueError(
            f"element file {path}, line {rows[1 + bad[0]][0]}: the normal has length "
            f"{length[bad[0]]:.4g}; expected a unit vector (within 1e-3)"
        )
    if len(wanted) > len(FILE_COLUMNS):
        channel = data[:, -1]
        bad = np.flatnonzero((channel < 0) | (channel != np.round(channel)))
        if bad.size:
            raise ValueError(
                f"element file {path}, line {rows[1 + bad[0]][0]}: channel must be a whole "
                f"number from 0, found {channel[bad[0]]:g}"
            )
        channels = channel.astype(np.int64)
    else:
        channels = np.arange(positions.shape[0], dtype=np.int64)
    return positions, normals / length[:, None], channels


def _read_lines(
    path: Path, rows: list[tuple[int, str]], width: int, index: list[int]
) -> NDArray[np.float64]:
    """The element lines one by one, naming the first that is not ``width`` finite numbers."""
    data = np.empty((len(rows), len(index)))
    for n, (line_no, line) in enumerate(rows):
        cells = line.split(",")
        if len(cells) != width:
            raise ValueError(
                f"element file {path}, line {line_no}: {len(cells)} values, expected {width}"
            )
        try:
            data[n] = [float(cells[i]) for i in index]
        except ValueError:
            raise ValueError(
                f"element file {path}, line {line_no}: not a number in {line!r}"
            ) from None
        if not np.all(np.isfinite(data[n])):
            raise ValueError(f"element file {path}, line {line_no}: values must be finite")
    return data


def _unique_rows(rows: NDArray) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Group index of each row of whole numbers and the size of each group (a lexsort: far
    faster than ``np.unique(axis=0)`` on floats)."""
    keys = rows.astype(np.int64)
    order = np.lexsort(keys.T[::-1])
    ordered = keys[order]
    new = np.r_[True, np.any(ordered[1:] != ordered[:-1], axis=1)]
    group = np.empty(keys.shape[0], np.int64)
    group[order] = np.cumsum(new) - 1
    return group, np.bincount(group)


def layout_from_elements(
    positions: NDArray, normals: NDArray, channels: NDArray, source: str = "elements"
) -> Layout:
    """The :class:`Layout` of single elements: grouped into vertical columns when the elements
    stand in columns (the same position across and the same normal) that all hold the same
    heights relative to their centre, otherwise one element a column (the sums are the same;
    columns share the vertical phase factor and are faster)."""
    positions = np.asarray(positions, float)
    normals = np.asarray(normals, float)
    _, counts = _unique_rows(np.round(positions / _TOLERANCE_M))
    if np.any(counts > 1):
        raise ValueError(f"{source}: two elements stand at the same position")
    group, counts = _unique_rows(
        np.round(np.hstack([positions[:, :2] / _TOLERANCE_M, normals * 1e9]))
    )
    first = np.full(counts.size, group.size)
    np.minimum.at(first, group, np.arange(group.size))
    order = np.argsort(first)  # columns in the order of their first element in the file
    if np.all(counts == counts[0]) and counts[0] > 1:
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        col = rank[group]
        # Elements sorted by column, then up the column: (columns, stack) indices.
        members = np.lexsort((positions[:, 2], col)).reshape(counts.size, counts[0])
        z = positions[members, 2]
        centre = z.mean(axis=1)
        offsets = z - centre[:, None]
        if np.all(np.abs(offsets - offsets[0]) <= _TOLERANCE_M):
            column_position = np.column_stack([positions[members[:, 0], :2], centre])
            return Layout(
                column_position=column_position,
                normal=normals[members[:, 0]],
                axis=np.array([0.0, 0.0, 1.0]),
                stack_m=offsets[0].copy(),
                channel=channels[members],
            )
    return Layout(
        column_position=positions.copy(),
        normal=normals.copy(),
        axis=np.array([0.0, 0.0, 1.0]),
        stack_m=np.zeros(1),
        channel=channels[:, None].copy(),
    )


def write_element_file(path: str | Path, layout: Layout, comment: str = "") -> None:
    """Write every element of ``layout`` (column by column, up each column) in the file format
    (for the script that makes a graph's element file, and tests)."""
    p = layout.positions().reshape(-1, 3)
    n = np.repeat(layout.normal, layout.stack_m.size, axis=0)
    c = layout.channel.reshape(-1)
    lines = [f"# {line}" for line in comment.splitlines()]
    lines.append(",".join([*FILE_COLUMNS, CHANNEL_COLUMN]))
    lines += [
        ",".join([*(f"{v:.7g}" for v in (*pos, *nrm)), str(int(ch))])
        for pos, nrm, ch in zip(p, n, c, strict=True)
    ]
    Path(path).write_text("\n".join(lines) + "\n")
