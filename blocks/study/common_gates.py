"""A study's pieces for single stores: errors against another store, per-azimuth profiles,
and several systems side by side on their common gates.

Differences of velocity and phi_DP are taken on their circles (the scorer's ``period`` of the
store's ``error_*`` variable). Two stores are compared only on the same grid: otherwise the
grid that differs is named and nothing is computed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .statistics import FIELDS, robust_std, wrap


class CompareError(Exception):
    """A comparison that cannot be made (one line, exit 2)."""


@dataclass
class Store:
    path: Path
    name: str
    azimuth: np.ndarray
    range: np.ndarray
    values: dict[str, np.ndarray]  # the estimate (or expected level) of each moment
    errors: dict[str, np.ndarray]  # the scorer's error, NaN off the scored gates
    periods: dict[str, float]
    requirements: dict[str, tuple[float, float]]
    units: dict[str, str]


def read_store(path: str | Path, sweep_index: int | None = None) -> Store:
    """One sweep of a finished store: ``sweep_index``, which a volume of several sweeps must
    name (comparing its first sweep alone would pass for the whole volume)."""
    from pasim_graph.fm301 import sweep_names
    from pasim_graph.store import NotAStoreError, open_finished, root_attrs, sweep_of

    path = Path(path)
    try:
        tree = open_finished(path)
        held = sweep_names(tree)
        if sweep_index is None and len(held) > 1:
            raise CompareError(
                f"{path}: a volume of {len(held)} sweeps ({held[0]} to {held[-1]}); "
                "name one with --sweep N"
            )
        sweep, attrs = sweep_of(tree, path, sweep_index or 0), root_attrs(tree)
    except NotAStoreError as exc:
        raise CompareError(str(exc)) from None
    if "azimuth" not in sweep.dims:
        raise CompareError(f"{path}: its beams do not run along azimuth (not a PPI)")
    values, errors, periods, reqs, units = {}, {}, {}, {}, {}
    for name in FIELDS:
        if name in sweep:
            values[name] = np.asarray(sweep[name].values, dtype=np.float64)
        err = sweep.get(f"error_{name}")
        if err is not None:
            errors[name] = np.asarray(err.values, dtype=np.float64)
            if "period" in err.attrs:
                periods[name] = float(err.attrs["period"])
            reqs[name] = (float(err.attrs["requirement_bias"]), float(err.attrs["requirement_std"]))
            units[name] = str(err.attrs.get("units", ""))
    name = str(attrs.get("study_system") or path.name.removesuffix(".zarr"))
    return Store(
        path,
        name,
        np.asarray(sweep["azimuth"].values, dtype=np.float64),
        np.asarray(sweep["range"].values, dtype=np.float64),
        values,
        errors,
        periods,
        reqs,
        units,
    )


def _span(v: np.ndarray, unit: str, scale: float) -> str:
    if not v.size:
        return "none"
    return f"{v.size} from {v[0] * scale:.2f} to {v[-1] * scale:.2f} {unit}"


def check_grids(a: Store, b: Store) -> None:
    """Refuse, naming the grid, two stores whose azimuths or ranges differ."""
    for what, x, y, unit, scale in (
        ("azimuth", a.azimuth, b.azimuth, "deg", 1.0),
        ("range", a.range, b.range, "km", 1e-3),
    ):
        if x.shape != y.shape or not np.allclose(x, y, atol=1e-3):
            raise CompareError(
                f"{a.path} and {b.path}: the {what} grids differ ({_span(x, unit, scale)} "
                f"against {_span(y, unit, scale)}); only stores of the same grid are compared"
            )


def stats(d: np.ndarray, requirement: tuple[float, float] | None = None) -> dict[str, Any]:
    x = d[np.isfinite(d)]
    out: dict[str, Any] = {
        "std": float(x.std(ddof=1)) if x.size > 1 else math.nan,
        "robust_std": robust_std(x),
        "bias": float(x.mean()) if x.size else math.nan,
        "count": int(x.size),
    }
    if requirement is not None:
        rb, rs = requirement
        out["requirement_bias"], out["requirement_std"] = rb, rs
        out["pass"] = bool(x.size > 1 and abs(out["bias"]) <= rb and out["std"] <= rs)
    return out


def errors_against(store: Store, ref: Store) -> dict[str, np.ndarray]:
    """Each moment of ``store`` minus ``ref``'s on the store's scored gates (on its circle)."""
    check_grids(store, ref)
    out = {}
    for name, err in store.errors.items():
        if name not in store.values or name not in ref.values:
            continue
        d = wrap(store.values[name] - ref.values[name], store.periods.get(name))
        out[name] = np.where(np.isfinite(err), d, np.nan)
    if not out:
        raise CompareError(f"{store.path} and {ref.path}: no moment scored in both")
    return out


def score_against(store: Store, ref: Store) -> dict[str, dict[str, Any]]:
    return {
        name: {**stats(d, store.requirements.get(name)), "units": store.units.get(name, "")}
        for name, d in errors_against(store, ref).items()
    }


def parse_by(text: str) -> float | None:
    """``azimuth`` (each beam) or ``azimuth:BIN`` (BIN degrees); the bin, None for beams."""
    what, _, size = text.partition(":")
    if what != "azimuth":
        raise CompareError(f"--by {text}: only azimuth is known (azimuth or azimuth:BIN)")
    if not size:
        return None
    try:
        b = float(size)
    except ValueError:
        raise CompareError(f"--by {text}: BIN must be a number of degrees") from None
    if not (math.isfinite(b) and 0 < b <= 360):
        raise CompareError(f"--by {text}: BIN must be more than 0 and at most 360 deg")
    return b


def by_azimuth(
    azimuth: np.ndarray, errors: dict[str, np.ndarray], bin_deg: float | None
) -> list[dict[str, Any]]:
    """Bias, std and count of each moment's error per beam or per azimuth bin (bins counted
    from the first beam's azimuth, unwrapped across north)."""
    az = np.rad2deg(np.unwrap(np.deg2rad(azimuth)))
    if bin_deg is None:
        keys = np.arange(az.size)
        centres = azimuth
    else:
        keys = np.floor((az - az[0]) / bin_deg).astype(int)
        centres = None
    rows = []
    for k in np.unique(keys):
        sel = keys == k
        centre = float(centres[sel][0]) if centres is not None else float((az[sel].mean()) % 360.0)
        row: dict[str, Any] = {"azimuth": centre, "beams": int(sel.sum())}
        for name, d in errors.items():
            row[name] = stats(d[sel])
        rows.append(row)
    return rows


def compare(stores: list[Store]) -> dict[str, Any]:
    """Every moment of several stores on the gates all of them scored: std, robust spread,
    bias and count per store, with the common count and each store's own count."""
    for s in stores[1:]:
        check_grids(stores[0], s)
    out: dict[str, Any] = {}
    for name in FIELDS:
        if not all(name in s.errors for s in stores):
            continue
        common = np.ones(stores[0].errors[name].shape, dtype=bool)
        for s in stores:
            common &= np.isfinite(s.errors[name])
        out[name] = {
            "common_count": int(common.sum()),
            "units": stores[0].units.get(name, ""),
            "requirement_std": stores[0].requirements[name][1],
            "stores": [
                {
                    **stats(np.where(common, s.errors[name], np.nan)),
                    "own_count": int(np.isfinite(s.errors[name]).sum()),
                }
                for s in stores
            ],
        }
    if not out:
        raise CompareError("the stores have no scored moment in common")
    return out


def names(stores: list[Store]) -> list[str]:
    """Column names: each store's system name, made unique with its file name."""
    base = [s.name for s in stores]
    return [
        n if base.count(n) == 1 else f"{n} ({s.path.parent.name}/{s.path.name})"
        for n, s in zip(base, stores, strict=True)
    ]
