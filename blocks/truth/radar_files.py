"""Truth from any radar file xradar opens: CfRadial 1 and 2, ODIM_H5, IRIS/Sigmet, UF,
Rainbow, GAMIC, Furuno (NEXRAD Level-II goes to the project's own reader, which beats
xradar's there: :mod:`pasim_blocks.truth.nexrad_io`).

The file's format is told from its first bytes (a gzip wrapper is looked through), the
backends that can read such a file are tried in turn, and the sweep nearest the requested
elevation is taken. Its fields are mapped onto the six moments by name (the standard names
and the common aliases: ``reflectivity``, ``differential_reflectivity``, ``TH``, ``UPHIDP``,
...) or by CF standard name; a moment the file lacks is absent (the run is then single
polarisation, or without width, and says so once), never guessed. The site's position, the
Nyquist velocity and the radar's frequency are read where the file has them.
"""

from __future__ import annotations

import contextlib
import gzip
import tempfile
import warnings
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from pasim_graph.fm301 import rhi_mode, sweep_names

from . import sizes
from .field_names import ALIASES, field_map, mapping_hint, unknown_names
from .gridding import (
    check_sector,
    clean_fields,
    drop_duplicate_radials,
    gate_width,
    nominal_spacing,
    sector_order,
    wrap360,
)
from .iris_rays import keep_iris_rays_in_order
from .nexrad_io import TruthSweep

_MAX_ELEVATION_MISMATCH_DEG = 1.0
#: Radials closer than this in azimuth (the median step) are not a PPI sweep's: a raster or
#: a fixed-pointing scan, whose azimuth hardly moves.
_MIN_SPACING_DEG = 0.01
#: A gzip-wrapped file is unpacked to a temporary file (xradar's backends read paths);
#: no radar sweep file is larger than this.
_MAX_UNPACKED_BYTES = 2 << 30


def _backends() -> dict[str, Callable[..., Any]]:
    import xradar.io as xio

    # xradar's IRIS reader labels each ray with the next ray's azimuth: undone here, where
    # every radar file PASIM reads is opened (see :mod:`.iris_rays`).
    keep_iris_rays_in_order()
    names = {
        "CfRadial 1": "open_cfradial1_datatree",
        "ODIM_H5": "open_odim_datatree",
        "GAMIC": "open_gamic_datatree",
        "IRIS/Sigmet": "open_iris_datatree",
        "UF": "open_uf_datatree",
        "Rainbow": "open_rainbow_datatree",
        "Furuno": "open_furuno_datatree",
    }
    return {label: getattr(xio, fn) for label, fn in names.items() if hasattr(xio, fn)}


def candidate_formats(head: bytes, path: Path) -> list[str]:
    """The formats a file may be in, from its first bytes (most likely first)."""
    if path.is_dir():
        return ["CfRadial 2 (Zarr)"]
    if head.startswith(b"\x89HDF"):
        return ["ODIM_H5", "GAMIC", "CfRadial 1"]
    if head.startswith(b"CDF"):
        return ["CfRadial 1"]
    if head[:2] == b"UF" or head[4:6] == b"UF":
        return ["UF"]
    if head.lstrip().startswith((b"<volume", b"<?xml")):
        return ["Rainbow"]
    return ["IRIS/Sigmet", "Furuno", "UF", "CfRadial 1"]


@contextlib.contextmanager
def _unwrapped(path: Path) -> Iterator[Path]:
    """``path`` itself, or a temporary unpacked copy of a gzip-wrapped file."""
    with path.open("rb") as f:
        wrapped = f.read(2) == b"\x1f\x8b"
    if not wrapped:
        yield path
        return
    with tempfile.TemporaryDirectory(prefix="pasim-truth-") as tmp:
        out = Path(tmp) / path.name.removesuffix(".gz")
        with gzip.open(path, "rb") as src, out.open("wb") as dst:
            copied = 0
            while piece := src.read(1 << 20):
                copied += len(piece)
                if copied > _MAX_UNPACKED_BYTES:
                    raise ValueError(
                        f"{path}: unpacks to more than {_MAX_UNPACKED_BYTES >> 30} GiB, more "
                        "than any radar sweep file; refused"
                    )
                dst.write(piece)
        yield out


def open_radar_file(path: str | Path) -> tuple[Any, str]:
    """Open a radar file with the xradar backend its format needs: (DataTree, format).

    Raises ``ValueError`` naming the file and each format tried when none reads it.
    """
    import xarray as xr

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"radar file not found (no such file): {path}")
    if path.is_dir():
        sizes.check_zarr(path)
        try:
            tree = xr.open_datatree(path, engine="zarr")  # lazy but for index coordinates
        except Exception as exc:
            raise ValueError(f"{path}: a folder, but not a CfRadial 2 Zarr store ({exc})") from None
        sweeps = sweep_names(tree)
        sizes.check_tree(f"{path} (CfRadial 2)", [(s, tree[s].to_dataset()) for s in sweeps])
        return tree, "CfRadial 2 (Zarr)"
    tried: list[str] = []
    with _unwrapped(path) as plain:
        with plain.open("rb") as f:
            head = f.read(64)
        # What the file declares, before a reader allocates it (a damaged header that h5py
        # or netCDF4 cannot read is left to the readers, which name it).
        with contextlib.suppress(OSError, KeyError, RuntimeError):
            if head.startswith(b"\x89HDF"):
                sizes.check_hdf5(plain, path)
            elif head.startswith(b"CDF"):
                sizes.check_netcdf3(plain, path)
        backends = _backends()
        for label in candidate_formats(head, plain):
            opener = backends.get(label)
            if opener is None:
                continue
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    tree = opener(str(plain))
                    sweeps = sweep_names(tree)
                    if not sweeps:
                        raise ValueError("no sweep in it")
                    sizes.check_tree(
                        f"{path} ({label})", [(s, tree[s].to_dataset()) for s in sweeps]
                    )
                    tree = tree.load()  # read now: a temporary copy goes away
                return tree, label
            except sizes.SizeError:
                raise
            except Exception as exc:
                first = str(exc).splitlines()[0] if str(exc) else ""
                first = first.replace(str(plain), plain.name)  # the file is named already
                if not any(c.isalpha() for c in first):  # KeyError(4): say it is a KeyError
                    first = f"{type(exc).__name__} {first}".strip()
                tried.append(f"{label}: {first[:100]}")
    raise ValueError(
        f"{path}: no radar-file reader opens it (tried NEXRAD Level-II by its header, then "
        + "; ".join(tried or ["no candidate format"])
        + "); a format Py-ART reads (MDV, CHL, NEXRAD Level 3 or CDM, ...) can be written as "
        "CfRadial first: pyart.io.write_cfradial(out, pyart.io.read(file))"
    )


def read_radar_sweep(
    path: str | Path,
    elevation_deg: float = 0.5,
    sector_deg: tuple[float, float] | None = None,
    margin_deg: float = 0.0,
    fields: Mapping[str, str] | None = None,
) -> TruthSweep:
    """The sweep of a radar file nearest ``elevation_deg``, as a truth sweep.

    Parameters and result as :func:`pasim_blocks.truth.nexrad_io.read_truth_sweep`;
    ``fields`` names the file's variable for a moment (the truth block's ``fields``), the
    others are found by name (:func:`field_map`).
    """
    return read_radar_sweeps(path, lambda _: [elevation_deg], sector_deg, margin_deg, fields)[0]


def read_radar_sweeps(
    path: str | Path,
    choose: Callable[[list[float]], list[float]],
    sector_deg: tuple[float, float] | None = None,
    margin_deg: float = 0.0,
    fields: Mapping[str, str] | None = None,
) -> list[TruthSweep]:
    """Several PPI sweeps of one radar file, opened once: ``choose`` is given the file's PPI
    fixed angles (deg, ascending) and returns the elevations to read (each the nearest sweep,
    as :func:`read_radar_sweep`)."""
    path = Path(path)
    sector, margin = check_sector(sector_deg, margin_deg)
    tree, kind = open_radar_file(path)
    return sweeps_from_tree(tree, kind, path, choose, sector, margin, fields)


@contextlib.contextmanager
def damaged(where: str, file: str | None = None) -> Iterator[None]:
    """Name ``where`` (the file and its sweep, RHI or variable) in a failure of numpy or an
    xradar accessor on a damaged or emptied file ("zero-size array to reduction operation",
    "attempt to get argmin of an empty sequence", "SVD did not converge", "float division by
    zero", a missing key): one line, not numpy's words alone. A refusal of ours (it names the
    file already) passes unchanged."""
    file = file or where.split(" (", 1)[0]
    try:
        yield
    except (
        ValueError,
        ArithmeticError,
        IndexError,
        KeyError,
        TypeError,
        OSError,
        RuntimeError,
        np.linalg.LinAlgError,
    ) as exc:
        text = str(exc).splitlines()[0] if str(exc) else ""
        if isinstance(exc, ValueError) and file in text:
            raise
        raise ValueError(
            f"{where}: damaged or empty, cannot be read ({type(exc).__name__}: {text[:160]})"
        ) from None


def sweep_modes(tree: Any, where: str = "radar file") -> list[tuple[str, float, str]]:
    """(name, fixed angle, mode) of each sweep of an opened radar file, in file order
    (``where``, the file, names it in a refusal)."""
    sweeps = sorted((str(c) for c in tree.children if str(c).startswith("sweep_")), key=_number)
    described = []
    for name in sweeps:
        with damaged(f"{where}, {name}"):
            ds = tree[name].to_dataset()
        mode = text_value(ds["sweep_mode"].values) if "sweep_mode" in ds else ""
        fixed = np.asarray(ds["sweep_fixed_angle"] if "sweep_fixed_angle" in ds else []).ravel()
        angle = float(fixed[0]) if len(fixed) else float("nan")
        if not -360.0 <= angle <= 360.0:
            raise ValueError(
                f"{where}, {name}: `sweep_fixed_angle` is "
                + (f"{angle:g} deg, not in [-360, 360]" if len(fixed) else "missing")
            )
        described.append((name, angle, mode))
    return described


def sweeps_from_tree(
    tree: Any,
    kind: str,
    path: Path,
    choose: Callable[[list[float]], list[float]],
    sector: tuple[float, float] | None,
    margin: float,
    fields: Mapping[str, str] | None = None,
) -> list[TruthSweep]:
    """:func:`read_radar_sweeps` on a file already opened (:func:`open_radar_file`)."""
    described = sweep_modes(tree, f"{path} ({kind})")
    ppi = [d for d in described if not rhi_mode(d[2])]
    if not ppi:
        raise ValueError(
            f"{path} ({kind}) holds only RHI sweeps (azimuths "
            + ", ".join(f"{a:g}" for _, a, _ in described)
            + " deg); the truth block reads PPI sweeps by elevation, or RHIs as a volume "
            "(sweeps: volume)"
        )
    out = []
    for elevation_deg in choose(sorted({a for _, a, _ in ppi})):
        distance = [abs(a - elevation_deg) for _, a, _ in ppi]
        best = ppi[int(np.argmin(distance))]
        if min(distance) > _MAX_ELEVATION_MISMATCH_DEG:
            angles = ", ".join(f"{a:.2f}" for _, a, _ in ppi)
            raise ValueError(
                f"{path}: no sweep within {_MAX_ELEVATION_MISMATCH_DEG} deg of elevation "
                f"{elevation_deg} deg; available fixed angles (deg): {angles}"
            )
        with damaged(f"{path} ({kind}), {best[0]}"):
            out.append(_truth_sweep(tree, kind, path, best, sector, margin, fields))
    return out


def sweep_axes(
    ds: Any, where: str, *, need_elevation: bool = False
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """A sweep's azimuth and elevation (deg, per ray; elevation ``None`` where the file has
    none and it is not needed) and range (m, per gate), checked: a sweep without its range
    (xradar then numbers the gates 0, 1, 2, ... as if they were metres), or with an angle no
    antenna points at, or a NaN, is refused naming ``where`` (the file and the sweep) and
    the variable, never wrapped or guessed."""
    names = ("azimuth", "range") + (("elevation",) if need_elevation else ())
    missing = [n for n in names if n not in ds.variables]
    if missing:
        raise ValueError(
            f"{where}: no `{missing[0]}` variable (the "
            + {"azimuth": "azimuth of each ray", "range": "distance of each gate"}.get(
                missing[0], "elevation of each ray"
            )
            + "); refused rather than numbered 0, 1, 2, ..."
        )
    azimuth = np.asarray(ds["azimuth"].values, np.float64).ravel()
    range_m = np.asarray(ds["range"].values, np.float64).ravel()
    elevation = (
        np.asarray(ds["elevation"].values, np.float64).ravel()
        if "elevation" in ds.variables
        else None
    )
    if azimuth.size == 0 or range_m.size == 0:
        raise ValueError(
            f"{where}: holds {azimuth.size} rays of {range_m.size} gates (the file is empty "
            "or truncated there)"
        )
    _check_angles(where, "azimuth", azimuth, -360.0, 360.0, "ray")
    if elevation is not None:
        _check_angles(where, "elevation", elevation, -90.0, 90.0, "ray")
    _check_angles(where, "range", range_m, 0.0, np.inf, "gate")
    step = np.diff(range_m)
    if np.any(step <= 0):
        k = int(np.flatnonzero(step <= 0)[0]) + 1
        raise ValueError(
            f"{where}: `range` does not increase ({range_m[k]:g} m after "
            f"{range_m[k - 1]:g} m at gate {k})"
        )
    return azimuth, elevation, range_m


def _check_angles(
    where: str, name: str, values: np.ndarray, low: float, high: float, item: str
) -> None:
    bad = ~(np.isfinite(values) & (values >= low) & (values <= high))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        unit = "m" if name == "range" else "deg"
        bounds = f"[{low:g}, {high:g}]" if np.isfinite(high) else f"finite and >= {low:g}"
        raise ValueError(
            f"{where}: `{name}` holds {values[k]:g} {unit}, not {bounds} (at "
            f"{int(bad.sum())} of its {values.size} {item}s)"
        )


def _truth_sweep(
    tree: Any,
    kind: str,
    path: Path,
    best: tuple[str, float, str],
    sector: tuple[float, float] | None,
    margin: float,
    fields: Mapping[str, str] | None = None,
) -> TruthSweep:
    ds = tree[best[0]].to_dataset()
    names = [str(n) for n in ds.data_vars if ds[n].dims == ("azimuth", "range")]
    standard = {n: str(ds[n].attrs.get("standard_name", "")) for n in names}
    where = f"{path} ({kind}), the {best[1]:.2f} deg sweep"
    mapping = field_map(names, standard, fields, where)
    if "DBZH" not in mapping:
        raise no_reflectivity(where, names, mapping)
    raw_azimuth, elevation, range_m = sweep_axes(ds, f"{path} ({kind}), {best[0]}")
    azimuth = wrap360(raw_azimuth)
    width = nominal_spacing(azimuth)
    if not width >= _MIN_SPACING_DEG:
        # rays repeated while the antenna stood (a raster's start), or one ray (NaN)
        width = nominal_spacing(np.unique(np.round(azimuth, 3)))
    if not width >= _MIN_SPACING_DEG:
        span = float(np.ptp(azimuth)) if azimuth.size else 0.0
        raise ValueError(
            f"{where} is not a PPI: its {azimuth.size} ray(s) lie within {span:.3g} deg of "
            f"azimuth (sweep_mode {best[2] or 'not given'!r}); the truth needs radials that "
            "step in azimuth (an RHI file is read as a volume: sweeps: volume)"
        )
    keep = drop_duplicate_radials(azimuth, width)
    order = keep[sector_order(azimuth[keep], sector, margin)]
    if order.size == 0 and sector is not None:
        raise ValueError(
            f"{where}: no radial within {margin:g} deg of the sector {sector[0]:g}:"
            f"{sector[1]:g} deg (its {keep.size} radials lie from {azimuth[keep].min():.1f} to "
            f"{azimuth[keep].max():.1f} deg); set the scan's sector inside them (--sector)"
        )
    values = {
        moment: np.asarray(ds[var].values, np.float32)[order] for moment, var in mapping.items()
    }
    site, nyquist = file_site(tree, ds, path), file_nyquist(ds)
    return TruthSweep(
        azimuth_deg=azimuth[order],
        elevation_deg=float(np.mean(elevation)) if elevation is not None else best[1],
        range_m=range_m,
        radial_width_deg=float(width),
        gate_width_m=gate_width(range_m),
        fields=clean_fields(values),
        nyquist_velocity_ms=nyquist,
        site=site,
        source=path.name,
        unmapped=tuple(unknown_names(names, mapping)),
    )


def no_reflectivity(where: str, names: list[str], mapping: dict[str, str]) -> ValueError:
    """The refusal of a sweep without a reflectivity field PASIM knows by name: its fields
    and how to name one."""
    unknown = unknown_names(names, mapping)
    return ValueError(
        f"{where} has no reflectivity field known by name (its fields: "
        f"{', '.join(names) or 'none'}); "
        + (mapping_hint("DBZH", unknown) if unknown else "none of them can be taken for it")
    )


def file_site(tree: Any, sweep: Any, path: Path) -> dict[str, Any]:
    """The radar's position, name and start time as a radar file records them (0 and '' where
    it does not)."""
    root = tree.to_dataset()
    start = header_time(root, "time_coverage_start", path)
    end = header_time(root, "time_coverage_end", path)
    if start is not None and end is not None and end < start:
        raise ValueError(
            f"{path}: `time_coverage_end` {_iso(end)} is before `time_coverage_start` "
            f"{_iso(start)}: the file's header times are damaged"
        )
    return {
        "latitude": _scalar(root, "latitude", sweep),
        "longitude": _scalar(root, "longitude", sweep),
        "altitude": _scalar(root, "altitude", sweep),
        "instrument_name": str(tree.attrs.get("instrument_name", path.stem)).strip(),
        "time_coverage_start": text_value(root["time_coverage_start"].values)
        if start is not None
        else "",
    }


#: The times a radar file's header may give: weather radars recorded from the 1940s, and a
#: file dated past 2100 (or before 1940: a year 1900 is a zeroed clock) has a damaged header.
EARLIEST, LATEST = np.datetime64("1940-01-01", "s"), np.datetime64("2100-01-01", "s")


def header_time(root: Any, name: str, path: Path) -> np.datetime64 | None:
    """The time a file's header gives under ``name`` (None where it gives none); refused,
    naming the file and the field, where it is not a time or not between 1940 and 2100."""
    text = text_value(root[name].values) if name in root else ""
    if not text:
        return None
    try:
        when = np.datetime64(text.rstrip("Z"))
    except ValueError:
        raise ValueError(f"{path}: `{name}` is {text[:40]!r}, not an ISO 8601 time") from None
    if np.isnat(when) or not EARLIEST <= when < LATEST:
        raise ValueError(
            f"{path}: `{name}` is {text[:40]}, not between 1940 and 2100: the file's header "
            "time is damaged (or its clock was not set)"
        )
    return when


def _iso(when: np.datetime64) -> str:
    return f"{np.datetime_as_string(when, unit='s')}Z"


def text_value(value: Any) -> str:
    """A text variable as text: a str, bytes (xradar's reading of a netCDF character array,
    as Radx writes times), or an array of characters or bytes (joined); NUL padding and
    spaces stripped."""
    array = np.asarray(value)
    if array.dtype.kind in "SU" and array.ndim:
        items = array.ravel().tolist()
    else:
        items = [array.item() if array.size == 1 else value]
    parts = [i.decode("utf-8", "replace") if isinstance(i, bytes) else str(i) for i in items]
    return "".join(parts).replace("\x00", "").strip()


def file_nyquist(sweep: Any) -> float:
    """The sweep's Nyquist velocity (the median of the rays'), NaN when not recorded."""
    if "nyquist_velocity" not in sweep:
        return float("nan")
    values = np.asarray(sweep["nyquist_velocity"].values, np.float64).ravel()
    values = values[np.isfinite(values)]
    return float(np.median(values)) if values.size else float("nan")


def _number(name: str) -> int:
    tail = name.rsplit("_", 1)[-1]
    return int(tail) if tail.isdigit() else 0


def _scalar(root: Any, name: str, sweep: Any) -> float:
    for ds in (root, sweep):
        if name in ds.variables:
            value = np.asarray(ds[name].values, np.float64).ravel()
            if value.size and np.isfinite(value[0]):
                return float(value[0])
    return 0.0


def is_level2(path: str | Path) -> bool:
    """True when the file is a NEXRAD Level-II volume (possibly gzip- or bzip2-wrapped)."""
    import bz2

    path = Path(path)
    if not path.is_file():
        return False
    with path.open("rb") as f:
        head = f.read(32)
    with contextlib.suppress(OSError, EOFError, ValueError):
        if head[:2] == b"\x1f\x8b":
            with gzip.open(path, "rb") as g:
                head = g.read(32)
        elif head[:3] == b"BZh":
            with bz2.open(path, "rb") as b:
                head = b.read(32)
    return head.startswith((b"AR2V", b"ARCHIVE2"))


__all__ = [
    "ALIASES",
    "damaged",
    "field_map",
    "file_nyquist",
    "file_site",
    "is_level2",
    "mapping_hint",
    "no_reflectivity",
    "open_radar_file",
    "read_radar_sweep",
    "read_radar_sweeps",
    "sweep_modes",
    "sweeps_from_tree",
    "text_value",
    "unknown_names",
]
