"""Range-height (RHI) radar files as a volume truth: the rays of the RHIs (one azimuth each)
regrouped into constant-elevation sweeps over those azimuths, so the weather channel reads
them in elevation like the sweeps of a PPI volume (:mod:`.volume`).

The elevation grid is the rays' median spacing from the lowest ray to the highest; each RHI
gives every grid elevation its nearest ray within half a spacing (none: no echo there). The
sweeps hold only the RHIs' azimuths, so the truth covers only those: a beam needs a pattern
support in azimuth inside them (the weather channel refuses it otherwise).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from pasim_graph.fm301 import rhi_mode

from .gridding import clean_fields, gate_width, wrap360
from .nexrad_io import TruthSweep
from .radar_files import (
    damaged,
    field_map,
    file_nyquist,
    file_site,
    no_reflectivity,
    sweep_axes,
    sweep_modes,
    unknown_names,
)


def only_rhis(tree: Any, where: str = "radar file") -> bool:
    """True when every sweep of the opened radar file (``where``, named in a refusal) is an
    RHI."""
    modes = sweep_modes(tree, where)
    return bool(modes) and all(rhi_mode(m) for _, _, m in modes)


def rhi_sweeps(
    tree: Any,
    kind: str,
    path: Path,
    choose: Callable[[list[float]], list[float]],
    fields: Mapping[str, str] | None = None,
) -> list[TruthSweep]:
    """Constant-elevation sweeps made of an RHI file's rays; ``choose`` is given the grid's
    elevations and returns those to keep (each the nearest grid elevation); ``fields`` names
    the file's variable for a moment, as for a PPI file."""
    with damaged(f"{path} ({kind}), its RHIs", str(path)):
        return _rhi_sweeps(tree, kind, path, choose, fields)


def _rhi_sweeps(
    tree: Any,
    kind: str,
    path: Path,
    choose: Callable[[list[float]], list[float]],
    given: Mapping[str, str] | None,
) -> list[TruthSweep]:
    rhis = []
    for name, angle, _ in sweep_modes(tree, f"{path} ({kind})"):
        ds = tree[name].to_dataset()
        _, elevation, range_m = sweep_axes(ds, f"{path} ({kind}), {name}", need_elevation=True)
        assert elevation is not None
        names = [str(n) for n in ds.data_vars if ds[n].ndim == 2]
        where = f"{path} ({kind}), the RHI at azimuth {angle:g} deg"
        standard = {n: str(ds[n].attrs.get("standard_name", "")) for n in names}
        mapping = field_map(names, standard, given, where)
        if "DBZH" not in mapping:
            raise no_reflectivity(where, names, mapping)
        unmapped = set(unknown_names(names, mapping))
        order = np.argsort(elevation, kind="stable")
        rhis.append(
            (
                float(wrap360(np.array([angle]))[0]),
                elevation[order],
                range_m,
                {m: np.asarray(ds[v].values, np.float32)[order] for m, v in mapping.items()},
                ds,
                unmapped,
            )
        )
    rhis.sort(key=lambda r: r[0])
    range_m = rhis[0][2]
    if any(r[2].shape != range_m.shape or not np.allclose(r[2], range_m) for r in rhis):
        raise ValueError(f"{path} ({kind}): its RHIs do not share one range axis")
    step = float(np.median(np.concatenate([np.diff(r[1]) for r in rhis])))
    if not step > 0:
        raise ValueError(f"{path} ({kind}): the RHIs' rays do not step in elevation")
    low, high = min(r[1][0] for r in rhis), max(r[1][-1] for r in rhis)
    grid = low + step * np.arange(int(np.floor((high - low) / step + 1e-9)) + 1)
    wanted = choose([float(g) for g in grid])
    rows = sorted({int(np.argmin(np.abs(grid - e))) for e in wanted})
    azimuth = np.array([r[0] for r in rhis])
    width = float(np.median(np.diff(azimuth))) if azimuth.size > 1 else 1.0
    moments = sorted(set.intersection(*(set(r[3]) for r in rhis)))
    site, nyquist = file_site(tree, rhis[0][4], path), file_nyquist(rhis[0][4])
    sweeps = []
    for k in rows:
        fields = {n: np.full((azimuth.size, range_m.size), np.nan, np.float32) for n in moments}
        for j, (_, el, _, values, _, _) in enumerate(rhis):
            ray = int(np.argmin(np.abs(el - grid[k])))
            if abs(el[ray] - grid[k]) <= step / 2 + 1e-6:
                for n in moments:
                    fields[n][j] = values[n][ray]
        sweeps.append(
            TruthSweep(
                azimuth_deg=azimuth,
                elevation_deg=float(grid[k]),
                range_m=range_m,
                radial_width_deg=width,
                gate_width_m=gate_width(range_m),
                fields=clean_fields(fields),
                nyquist_velocity_ms=nyquist,
                site=site,
                source=path.name,
                unmapped=tuple(sorted(set.intersection(*(r[5] for r in rhis)))),
            )
        )
    return sweeps
