"""A finished run as a file other radar tools read: CF/Radial 1, CF/Radial 2 or ODIM_H5.

``pasim export STORE --format FORMAT`` (:mod:`pasim_blocks.commands.export`) calls
:func:`export_store`. The writers are xradar's own (``xradar.io.to_cfradial1``,
``to_cfradial2``, ``to_odim``); this module only chooses what goes into the file and how ODIM
quantises it:

- every sweep of the store (a volume exports all of them);
- the estimated moments under their own names (``DBZH``, ``ZDR``, ``RHOHV``, ``PHIDP``,
  ``VRADH``, ``WRADH``, those the store holds), the truth on the same gates as extra fields
  under the store's names (``truth_DBZH``, ...; :func:`truth_attrs`); the errors, the
  scored-gate mask, the expected SNR ``SNRH`` (minus infinity where there is no echo, which
  ODIM cannot code) and the I/Q cubes (not radar moments) stay in the store;
- CF/Radial files keep each field as the store's float32, bit for bit; ODIM_H5 stores each as
  a 16-bit unsigned integer with the gain and offset of :data:`ODIM_CODING` (value =
  offset + gain x raw), so a value read back is within ``gain / 2`` of the store's
  (:func:`odim_bound`), the raw value 65535 is *nodata* (a censored or missing gate, NaN in
  the store) and 0 is *undetect* (never written: the ranges below start at raw 1).

Everything is checked before anything is written, and the file is written under a temporary
name beside ``out`` and renamed only when whole, so a refused or failed export leaves nothing.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph.fm301 import SWEEP_MODE_PPI, SWEEP_MODE_RHI, sweep_names
from pasim_graph.store import DONE, NotAStoreError, beam_dimension, open_finished

__all__ = [
    "FORMATS",
    "MOMENTS",
    "ODIM_CODING",
    "ExportError",
    "Exported",
    "default_out",
    "export_store",
    "export_tree",
    "odim_bound",
]

#: The formats, each with what writes it and the file suffix of its default name.
FORMATS: dict[str, tuple[str, str]] = {
    "cfradial1": ("CF/Radial 1.2 netCDF4, xradar.io.to_cfradial1", ".nc"),
    "cfradial2": ("CF/Radial 2.0 (FM-301) netCDF4, xradar.io.to_cfradial2", ".nc"),
    "odim": ("ODIM_H5 2.2 (PVOL, or SCAN for one sweep), xradar.io.to_odim", ".h5"),
}

#: The estimated moments; each goes with its truth ``truth_<name>``.
MOMENTS = ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH")
TRUTH = "truth_"
#: Root attributes of a store that describe its writing (chunk flags, arrays, tasks, resume
#: key), not the radar volume: left out of an export.
STORE_ATTRS = (
    "pasim_complete",
    "pasim_arrays",
    "pasim_tasks",
    "pasim_run_key",
    "pasim_inputs",
    "chunk_beams",
)

#: ODIM_H5 coding of each field (its truth too) as uint16: (gain, offset); the values that fit
#: are offset + gain x [1, 65534]. DBZH: -327.67 to 327.66 dBZ; ZDR: -32.767 to
#: 32.766 dB; RHOHV: -0.6553 to 5.9980; PHIDP: -655.34 to 655.32 deg; VRADH and WRADH:
#: -327.67 to 327.66 m/s.
ODIM_CODING: dict[str, tuple[float, float]] = {
    "DBZH": (0.01, -327.68),
    "ZDR": (0.001, -32.768),
    "RHOHV": (0.0001, -0.6554),
    "PHIDP": (0.02, -655.36),
    "VRADH": (0.01, -327.68),
    "WRADH": (0.01, -327.68),
}
ODIM_NODATA = 65535
ODIM_UNDETECT = 0
#: The ``what/source`` of an exported ODIM file (ODIM asks for one of NOD, RAD, WMO).
ODIM_SOURCE = "NOD:pasim,PLC:PASIM-graph simulation"


class ExportError(ValueError):
    """A store, format or output that cannot be exported; the message is one line."""


@dataclass(frozen=True)
class Exported:
    """What :func:`export_store` wrote."""

    path: Path
    sweeps: list[str]
    fields: list[str]


def coding_of(name: str) -> tuple[float, float]:
    """The ODIM (gain, offset) of a field or of its truth."""
    return ODIM_CODING[name.removeprefix(TRUTH)]


def odim_bound(name: str) -> float:
    """How far a value read back from an ODIM export may be from the store's: half the gain
    (rounding to the nearest integer), plus the float32 rounding of the store's value and of
    the decoded one."""
    gain, offset = coding_of(name)
    largest = abs(offset) + gain * ODIM_NODATA
    return gain / 2 + 2 * float(np.finfo(np.float32).eps) * largest


def default_out(store: str | Path, fmt: str) -> Path:
    """The file a store exports to without ``--out``: its name, with the format and suffix,
    in the current folder (``run.zarr`` -> ``run_cfradial1.nc``)."""
    stem = Path(store).name.removesuffix(".zarr") or "store"
    return Path(f"{stem}_{fmt}{FORMATS[fmt][1]}")


def check_format(fmt: str) -> None:
    if fmt not in FORMATS:
        raise ExportError(f"--format {fmt}: expected one of {', '.join(FORMATS)}")


def check_out(out: Path, store: str | Path) -> None:
    """Refuse an output that exists, whose folder does not, or inside the store (a file put
    there would be a foreign file in it)."""
    if out.exists() or out.is_symlink():
        raise ExportError(f"{out} exists; it is left untouched: choose another --out")
    if not out.resolve().parent.is_dir():
        raise ExportError(f"--out {out}: the folder {out.parent} does not exist")
    if Path(store).resolve() in out.resolve().parents:
        raise ExportError(f"--out {out} is inside the store {store}; write it elsewhere")


def _fields(sweep: xr.Dataset, beam_dim: str) -> list[str]:
    names = [*MOMENTS, *(TRUTH + m for m in MOMENTS)]
    return [n for n in names if n in sweep.data_vars and sweep[n].dims == (beam_dim, "range")]


def export_tree(tree: xr.DataTree, store: str | Path) -> xr.DataTree:
    """An in-memory FM-301 volume of a finished run's tree holding what is exported (see the
    module's docstring): the root's site and volume variables, and each sweep's exported fields
    with its coordinates and sweep metadata, every zarr encoding dropped."""
    sweeps = sweep_names(tree)
    if not sweeps:
        raise ExportError(f"{store}: holds no sweep to export")
    root = tree["/"].to_dataset().drop_vars([DONE], errors="ignore")
    root = root.drop_encoding().load()
    root.attrs = {k: v for k, v in tree.attrs.items() if k not in STORE_ATTRS}
    root.attrs.setdefault("history", "")
    root.attrs.setdefault("instrument_name", "pasim")
    out = {"/": root}
    for name in sweeps:
        sweep = tree[name].to_dataset()
        beam_dim = beam_dimension(sweep)
        fields = _fields(sweep, beam_dim)
        if not any(f in MOMENTS for f in fields):
            raise ExportError(
                f"{store}: {name} holds none of the moments {', '.join(MOMENTS)}; nothing to export"
            )
        keep = [
            n
            for n, v in sweep.data_vars.items()
            if n in fields or (v.ndim <= 1 and v.dims in ((), (beam_dim,)))
        ]
        sweep = sweep[keep].drop_encoding().load()
        for field in fields:
            if field.startswith(TRUTH):
                sweep[field].attrs = truth_attrs(field, sweep[field].attrs)
        out[name] = sweep
    return xr.DataTree.from_dict(out)


def truth_attrs(name: str, attrs: dict[str, Any]) -> dict[str, Any]:
    """A truth field's attributes in an exported file: its moment's standard name and units,
    its own ``short_name`` and a ``long_name`` that says it is the truth, so that a tool that
    goes by either never takes it for the estimate (the store gives both the moment's)."""
    long_name = attrs.get("long_name", name.removeprefix(TRUTH))
    return {**attrs, "short_name": name, "long_name": f"{long_name}, truth (simulation input)"}


def check_odim_scans(tree: xr.DataTree, store: str | Path) -> None:
    """Refuse an RHI for ODIM: its polar volume (PVOL, SCAN) holds PPIs only, and an RHI
    written there is read back with azimuth and elevation exchanged (Py-ART's reader)."""
    for name, node in tree.children.items():
        mode = str(node["sweep_mode"].values) if "sweep_mode" in node.data_vars else SWEEP_MODE_PPI
        if mode == SWEEP_MODE_RHI:
            raise ExportError(
                f"{store}: {name} is an RHI, which ODIM_H5's polar volume cannot hold; "
                "export it as cfradial1 or cfradial2"
            )


def odim_encode(tree: xr.DataTree, store: str | Path) -> None:
    """Give each exported field of ``tree`` its ODIM uint16 coding (in place), refusing a
    value the coding cannot hold."""
    for node in tree.children.values():
        for name, var in node.data_vars.items():
            if str(name).removeprefix(TRUTH) not in ODIM_CODING or var.ndim != 2:
                continue
            gain, offset = coding_of(str(name))
            values = var.values[~np.isnan(var.values)]
            low, high = offset + gain * 1, offset + gain * (ODIM_NODATA - 1)
            if values.size and (values.min() < low or values.max() > high):
                raise ExportError(
                    f"{store}: {node.name}/{name} spans {values.min():g} to {values.max():g}, "
                    f"beyond what ODIM's 16-bit coding of it holds ({low:g} to {high:g})"
                )
            var.encoding = {
                "dtype": np.dtype("uint16"),
                "scale_factor": gain,
                "add_offset": offset,
                "_FillValue": ODIM_NODATA,
                "_Undetect": ODIM_UNDETECT,
            }


def _chars(ds: xr.Dataset) -> xr.Dataset:
    text = [n for n, v in ds.data_vars.items() if v.dtype.kind == "U"]
    return ds.assign({n: ds[n].astype("S") for n in text})


def _write(tree: xr.DataTree, fmt: str, path: Path) -> None:
    import xradar

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if fmt == "cfradial1":
            # CF/Radial 1 holds strings as character arrays (Py-ART reads them so).
            tree = tree.map_over_datasets(_chars)
            xradar.io.to_cfradial1(tree, str(path))
        elif fmt == "cfradial2":
            xradar.io.to_cfradial2(tree, str(path), engine="netcdf4")
        else:
            xradar.io.to_odim(tree, str(path), source=ODIM_SOURCE, optional_how=True)


def export_store(store: str | Path, fmt: str, out: str | Path | None = None) -> Exported:
    """Write every sweep of the finished run ``store`` to ``out`` (default
    :func:`default_out`) in ``fmt``, one of :data:`FORMATS`.

    Raises :class:`ExportError` (one line, nothing written) for an unknown format, an output
    that exists or whose folder does not, a path that is not a finished PASIM-graph store
    (missing, another directory, an interrupted or damaged run), a store without moments, an
    RHI or a field beyond its coding for ODIM, or a file the writer cannot write.
    """
    check_format(fmt)
    path = Path(out) if out is not None else default_out(store, fmt)
    check_out(path, store)
    try:
        tree = open_finished(store)
    except NotAStoreError as exc:
        raise ExportError(str(exc)) from None
    with tree:
        volume = export_tree(tree, store)
    if fmt == "odim":
        check_odim_scans(volume, store)
        odim_encode(volume, store)
    partial = path.with_name(f".{path.name}.partial-{os.getpid()}")
    try:
        _write(volume, fmt, partial)
        check_out(path, store)  # nothing appeared there while the file was written
        os.replace(partial, path)
    except ExportError:
        raise
    except (OSError, ValueError, KeyError, TypeError) as exc:
        # A full disk, an unwritable folder, or a store xradar's writer cannot map.
        raise ExportError(f"--out {path}: could not write {fmt} ({exc})") from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            partial.unlink()
    sweeps = list(volume.children)
    fields: set[str] = set()
    for name in sweeps:
        sweep = volume[name].to_dataset()
        fields.update(_fields(sweep, beam_dimension(sweep)))
    return Exported(path, sweeps, sorted(fields))
