"""A simulated sweep as Py-ART sees it, and the fields the algorithms store.

Every algorithm block builds a :class:`pyart.core.Radar` in memory from the whole sweep's
arrays (one PPI sweep, its azimuths, elevations and gate ranges), runs Py-ART on it, and
returns :data:`ALGORITHM_FIELDS`: each product under its own name, and ``error_<name>``, the
product minus the same algorithm's ideal answer from the truth on the gates the scorer scored,
which ``pasim score`` lists beside the moments.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import DATASET, PortType, Schema, Var

#: Each product the algorithms store: units, description, and the requirement (bias, std)
#: its error is judged against. Velocity and reflectivity take the NEXRAD moments'
#: (paper Table 3); KDP and rain rate have no NEXRAD requirement: indicative values.
PRODUCTS: dict[str, tuple[str, str, tuple[float, float]]] = {
    "VRADH_DEALIASED_REGION": ("m s-1", "radial velocity dealiased, region-based", (1.0, 1.0)),
    "VRADH_DEALIASED_UNWRAP": ("m s-1", "radial velocity dealiased, unwrap-phase", (1.0, 1.0)),
    "DBZH_ZPHI": ("dBZ", "reflectivity corrected for attenuation, Z-PHI", (1.0, 1.0)),
    "AH_ZPHI": ("dB km-1", "specific attenuation, Z-PHI", (0.05, 0.1)),
    "KDP_MAESAKA": ("degrees km-1", "specific differential phase, Maesaka", (0.1, 0.3)),
    "KDP_VULPIANI": ("degrees km-1", "specific differential phase, Vulpiani", (0.1, 0.3)),
    "KDP_SCHNEEBELI": ("degrees km-1", "specific differential phase, Schneebeli", (0.1, 0.3)),
    "DBZH_DESPECKLED": ("dBZ", "reflectivity with speckles (small regions) removed", (1.0, 1.0)),
    "RATE_Z": ("mm h-1", "rain rate from reflectivity (power law)", (1.0, 2.0)),
    "RATE_KDP": ("mm h-1", "rain rate from KDP (power law)", (1.0, 2.0)),
}

_DIMS = ("beam", "range")
#: What the algorithm blocks output: any of the products, their errors and their ideal
#: answers from the truth (``ideal_<name>``), on the beam x range grid.
ALGORITHM_FIELDS = PortType(
    "algorithm_fields",
    DATASET,
    _DIMS,
    "cfradial",
    Schema(
        {
            **{n: Var("float32", _DIMS, u, d, required=False) for n, (u, d, _) in PRODUCTS.items()},
            **{
                f"ideal_{n}": Var(
                    "float32", _DIMS, u, f"{d}: the same algorithm on the truth", required=False
                )
                for n, (u, d, _) in PRODUCTS.items()
            },
            **{
                f"error_{n}": Var(
                    "float32", _DIMS, u, f"{n} minus its ideal answer", required=False
                )
                for n, (u, _, _) in PRODUCTS.items()
            },
        }
    ),
)


def need(ds: xr.Dataset, block: str, *names: str) -> None:
    """Refuse, in one line, a sweep that lacks a field the algorithm reads."""
    missing = [n for n in names if n not in ds]
    if missing:
        raise ValueError(
            f"{block} needs {', '.join(missing)} in the sweep (not computed: was the run "
            "limited with --outputs, or is the truth single-polarisation?)"
        )


def pyart() -> Any:
    """Py-ART, imported without its banner (it prints one to standard output, which holds a
    run's score table)."""
    import os

    os.environ.setdefault("PYART_QUIET", "1")
    import pyart as module

    return module


def make_radar(moments: xr.Dataset, frequency_hz: float | None = None) -> Any:
    """An in-memory Py-ART radar of one PPI sweep on the grid of ``moments`` (beam, range),
    without fields (:func:`add_field` adds them)."""
    radar = pyart().testing.make_empty_ppi_radar(moments.sizes["range"], moments.sizes["beam"], 1)

    radar.range["data"] = np.asarray(moments["range"].values, np.float64)
    for name in ("azimuth", "elevation"):
        if name in moments.coords:
            getattr(radar, name)["data"] = np.asarray(moments[name].values, np.float64)
    radar.fixed_angle["data"] = np.array([float(np.median(radar.elevation["data"]))])
    radar.init_gate_x_y_z()
    radar.init_gate_altitude()
    params: dict[str, Any] = {}
    if "nyquist_velocity" in moments:
        params["nyquist_velocity"] = {"data": np.asarray(moments["nyquist_velocity"].values)}
    if frequency_hz is not None:
        params["frequency"] = {"data": np.array([frequency_hz])}
    radar.instrument_parameters = params
    return radar


def add_field(radar: Any, name: str, values: np.ndarray, units: str = "") -> None:
    """Add ``values`` (beam x range, NaN where there is no data) as a masked field."""
    data = np.ma.masked_invalid(np.asarray(values, np.float64))
    radar.add_field(name, {"data": data, "units": units}, replace_existing=True)


def filled(field: Any) -> np.ndarray:
    """A Py-ART field's data as float32 with NaN where it is masked."""
    data = field["data"] if isinstance(field, dict) else field
    return np.ma.filled(np.ma.asarray(data, dtype=np.float64), np.nan).astype(np.float32)


def product(
    name: str, estimate: np.ndarray, ideal: np.ndarray, scored: np.ndarray, rule: str
) -> dict[str, tuple[tuple[str, str], np.ndarray, dict[str, Any]]]:
    """The stored variables of one product: the estimate, its ideal answer from the truth, and
    their difference on the ``scored`` gates (the scorer's rule, ``rule``), marked as an error
    field that ``pasim score`` reduces to bias and standard deviation."""
    units, doc, (req_b, req_s) = PRODUCTS[name]
    est = np.asarray(estimate, np.float32)
    ref = np.asarray(ideal, np.float32)
    err = np.where(scored & np.isfinite(est) & np.isfinite(ref), est - ref, np.nan)
    return {
        name: (_DIMS, est, {"units": units, "long_name": doc}),
        f"ideal_{name}": (
            _DIMS,
            ref,
            {"units": units, "long_name": f"{doc}: the same algorithm on the truth"},
        ),
        f"error_{name}": (
            _DIMS,
            err.astype(np.float32),
            {
                "pasim_role": "error",
                "moment": name,
                "truth_variable": f"ideal_{name}",
                "units": units,
                "requirement_bias": req_b,
                "requirement_std": req_s,
                "scored": rule,
                "long_name": f"{name} minus the same algorithm's answer from the truth",
            },
        ),
    }


def scored_gates(scores: xr.Dataset) -> tuple[np.ndarray, str]:
    """The scorer's scored gates and its rule."""
    scored = np.asarray(scores["scored"].values).astype(bool)
    return scored, str(scores["scored"].attrs.get("scored", ""))
