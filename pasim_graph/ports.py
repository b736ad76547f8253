"""Typed ports and parameters, declared on a block class.

A port type is a signal kind plus dtype, dimensions and units; two ports connect only when
all four agree. A port that carries an ``xarray.Dataset`` also declares its :class:`Schema`:
the variables it holds (dtype, dimensions, units) and its required attributes, checked on every
edge at validation and against what a block actually returns at run time. A parameter declares
its type, default, unit, bounds and a one-line doc once, and that declaration drives
validation, the command line and the JSON interface.
"""

from __future__ import annotations

import difflib
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

#: The dimension along which an executor splits a scan into chunks. A port whose type has it
#: carries one chunk of beams; a port without it carries data shared by every chunk.
BEAM_DIM = "beam"

#: dtype of a port that carries an ``xarray.Dataset`` (a bundle of named, labelled arrays).
DATASET = "dataset"

#: dtype families a :class:`Var` may declare instead of one numpy dtype.
_FAMILIES: dict[str, type] = {
    "floating": np.floating,
    "complexfloating": np.complexfloating,
    "integer": np.integer,
    "bool": np.bool_,
    "str": np.str_,
    "datetime64": np.datetime64,
}


def _dtype_ok(declared: str, actual: np.dtype) -> bool:
    if declared in _FAMILIES:
        family = _FAMILIES[declared]
        if declared == "str":
            return actual.kind in "UO"  # numpy strings, or Python str objects
        return bool(np.issubdtype(actual, family))
    return actual == np.dtype(declared)


def _dtype_feeds(out: str, into: str) -> bool:
    """An output variable of dtype ``out`` is acceptable to an input that declares ``into``."""
    if out == into:
        return True
    if into in _FAMILIES and out not in _FAMILIES:
        return _dtype_ok(into, np.dtype(out))
    return False


@dataclass(frozen=True)
class Var:
    """One variable (data variable or coordinate) of a Dataset port.

    Parameters
    ----------
    dtype : str
        numpy dtype name (``"float32"``) or a family: ``floating``, ``complexfloating``,
        ``integer``, ``bool``, ``str``, ``datetime64``.
    dims : tuple of str
        Dimension names in order (``()`` for a scalar).
    units : str
        Value of the variable's ``units`` attribute, which it must carry; ``""`` when the
        variable has no units (flags, names, counts).
    doc : str
        One line.
    required : bool
        Always present; otherwise present only for some runs (``--outputs``, single
        polarisation) and checked when present.
    """

    dtype: str
    dims: tuple[str, ...] = ()
    units: str = ""
    doc: str = ""
    required: bool = True

    def describe(self) -> str:
        dims = ", ".join(self.dims)
        units = f" {self.units}" if self.units else ""
        return f"{self.dtype} ({dims}){units}"

    def to_json(self, name: str) -> dict[str, Any]:
        return {
            "name": name,
            "dtype": self.dtype,
            "dims": list(self.dims),
            "units": self.units,
            "doc": self.doc,
            "required": self.required,
        }


@dataclass(frozen=True)
class Attr:
    """A Dataset attribute a port declares: type (``float``, ``int``, ``str``) and a doc."""

    type: str = "float"
    doc: str = ""
    required: bool = True

    def check(self, value: Any) -> str | None:
        if self.type == "str":
            ok = isinstance(value, str)
        elif self.type == "int":
            ok = isinstance(value, int | np.integer) and not isinstance(value, bool)
        else:
            ok = isinstance(value, int | float | np.integer | np.floating) and not isinstance(
                value, bool
            )
        return None if ok else f"expected {self.type}, found {type(value).__name__} {value!r}"


class Schema:
    """What a Dataset port holds: its variables (with coordinates) and required attributes.

    Parameters
    ----------
    variables : mapping of str to Var
        Every variable and coordinate the Dataset may hold. Nothing else may be in it.
    attrs : mapping of str to Attr
        Attributes the Dataset carries. Others are allowed (provenance, notes).
    """

    def __init__(
        self, variables: Mapping[str, Var], attrs: Mapping[str, Attr] | None = None
    ) -> None:
        self.variables: dict[str, Var] = dict(variables)
        self.attrs: dict[str, Attr] = dict(attrs or {})

    def _key(self) -> tuple[Any, ...]:
        return (tuple(sorted(self.variables.items())), tuple(sorted(self.attrs.items())))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Schema) and self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def __repr__(self) -> str:
        return f"Schema({', '.join(self.variables)})"

    def feeds(self, into: Schema) -> list[str]:
        """Why a Dataset of this schema cannot feed an input declaring ``into`` (empty if it can).

        The input's required variables and attributes must be provided, always, by the output;
        every variable both declare must agree in dtype, dimensions and units.
        """
        out: list[str] = []
        for name, want in into.variables.items():
            have = self.variables.get(name)
            if have is None:
                if want.required:
                    out.append(f"variable {name!r} ({want.describe()}) is not provided")
                continue
            if want.required and not have.required:
                out.append(f"variable {name!r} is needed but only sometimes provided")
            diff = []
            if not _dtype_feeds(have.dtype, want.dtype):
                diff.append(f"dtype {have.dtype} vs {want.dtype}")
            if have.dims != want.dims:
                diff.append(f"dims ({', '.join(have.dims)}) vs ({', '.join(want.dims)})")
            if have.units != want.units:
                diff.append(f"units {have.units!r} vs {want.units!r}")
            if diff:
                out.append(f"variable {name!r}: {'; '.join(diff)}")
        for name, attr in into.attrs.items():
            if attr.required and not (name in self.attrs and self.attrs[name].required):
                out.append(f"attribute {name!r} ({attr.type}) is not always provided")
        return out

    def check(self, ds: Any) -> list[str]:
        """What is wrong with an ``xarray.Dataset`` against this schema (empty when it fits)."""
        out: list[str] = []
        absent = [n for n in self.variables if n not in ds.variables]
        for name in sorted(map(str, ds.variables)):
            if name not in self.variables:
                # A misspelling names the variable it stands for, which is then missing.
                near = difflib.get_close_matches(name, absent, n=1, cutoff=0.6)
                hint = f"; a misspelling of {near[0]!r}, which is missing?" if near else ""
                out.append(
                    f"variable {name!r} is not declared (declared: {', '.join(self.variables)})"
                    + hint
                )
        for name, var in self.variables.items():
            if name not in ds.variables:
                if var.required:
                    out.append(f"required variable {name!r} ({var.describe()}) is missing")
                continue
            v = ds.variables[name]
            if tuple(v.dims) != var.dims:
                out.append(
                    f"variable {name!r} has dims ({', '.join(map(str, v.dims))}), "
                    f"declared ({', '.join(var.dims)})"
                )
            if not _dtype_ok(var.dtype, v.dtype):
                out.append(f"variable {name!r} has dtype {v.dtype}, declared {var.dtype}")
            units = v.attrs.get("units", "")
            if units != var.units:
                out.append(f"variable {name!r} has units {units!r}, declared {var.units!r}")
        for name, attr in self.attrs.items():
            if name not in ds.attrs:
                if attr.required:
                    out.append(f"required attribute {name!r} ({attr.type}) is missing")
                continue
            err = attr.check(ds.attrs[name])
            if err:
                out.append(f"attribute {name!r}: {err}")
        return out

    def to_json(self) -> dict[str, Any]:
        return {
            "variables": [v.to_json(n) for n, v in self.variables.items()],
            "attrs": [
                {"name": n, "type": a.type, "doc": a.doc, "required": a.required}
                for n, a in self.attrs.items()
            ],
        }

    def lines(self) -> list[str]:
        """One line per variable and attribute, for ``pasim blocks`` and the block docs."""
        out = []
        for name, v in self.variables.items():
            opt = "" if v.required else " (optional)"
            out.append(f"{name}: {v.describe()}{opt}  {v.doc}".rstrip())
        for name, a in self.attrs.items():
            opt = "" if a.required else " (optional)"
            out.append(f"@{name}: {a.type}{opt}  {a.doc}".rstrip())
        return out


@dataclass(frozen=True)
class PortType:
    """What flows through a port: signal kind, dtype, dimensions and units.

    Parameters
    ----------
    kind : str
        Signal kind, e.g. ``"iq"`` or ``"truth"``; says what the numbers mean.
    dtype : str
        numpy dtype name (``"complex64"``) or ``"dataset"`` for an ``xarray.Dataset``.
    dims : tuple of str
        Dimension names in order; ``"beam"`` marks data chunked over beams.
    units : str
        Physical units (``"sqrt(W)"``, ``"W"``) or a convention name (``"cfradial"``).
    schema : Schema, optional
        What a ``"dataset"`` port holds; every Dataset port declares one.
    """

    kind: str
    dtype: str
    dims: tuple[str, ...] = ()
    units: str = "1"
    schema: Schema | None = field(default=None, compare=True)

    @property
    def per_beam(self) -> bool:
        """True when the data is split over beams (one chunk at a time)."""
        return BEAM_DIM in self.dims

    def mismatch(self, other: PortType) -> list[str]:
        """Why this (output) type cannot feed ``other`` (an input); empty when it can.

        Kind, dtype, dimensions and units must be equal; a Dataset must provide every variable
        and attribute the input's schema requires, with the same dtype, dimensions and units.
        """
        out = []
        for name in ("kind", "dtype", "dims", "units"):
            a, b = getattr(self, name), getattr(other, name)
            if a != b:
                out.append(f"{name} {_fmt(a)} vs {_fmt(b)}")
        if not out and self.schema is not None and other.schema is not None:
            out += self.schema.feeds(other.schema)
        return out

    def check(self, value: Any) -> list[str]:
        """What is wrong with a value a block returned for a port of this type."""
        if self.dtype == DATASET:
            import xarray as xr

            if not isinstance(value, xr.Dataset):
                return [f"expected an xarray.Dataset, found {type(value).__name__}"]
            return self.schema.check(value) if self.schema is not None else []
        if not isinstance(value, np.ndarray):
            return [f"expected a numpy array of {self.dtype}, found {type(value).__name__}"]
        out = []
        if value.dtype != np.dtype(self.dtype):
            out.append(f"dtype {value.dtype}, declared {self.dtype}")
        if value.ndim != len(self.dims):
            out.append(
                f"{value.ndim} dimensions, declared {len(self.dims)} ({', '.join(self.dims)})"
            )
        return out

    def describe(self) -> str:
        dims = ", ".join(self.dims)
        return f"{self.kind}[{self.dtype}; ({dims}); {self.units}]"

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "kind": self.kind,
            "dtype": self.dtype,
            "dims": list(self.dims),
            "units": self.units,
        }
        if self.schema is not None:
            out["schema"] = self.schema.to_json()
        return out


def _fmt(value: Any) -> str:
    if isinstance(value, tuple):
        return "(" + ", ".join(value) + ")"
    return repr(value)


@dataclass(frozen=True)
class Input:
    """An input port declared on a block class (``pulse = Input(PortType(...), doc=...)``)."""

    type: PortType
    doc: str = ""
    required: bool = True
    name: str = ""

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "type": self.type.to_json(),
            "doc": self.doc,
            "required": self.required,
        }


@dataclass(frozen=True)
class Output:
    """An output port declared on a block class.

    ``store`` names the run product this port feeds, when the executor should write it: the
    port then carries an ``xarray.Dataset`` whose variables go into the output volume.
    ``"moments"`` is always written, ``"iq"`` only when the run asks to save I/Q.
    ``fields`` lists the variables such a Dataset can hold, so that a run can ask for some of
    them (``pasim run --outputs DBZH``) and be checked before it starts.
    """

    type: PortType
    doc: str = ""
    store: str | None = None
    name: str = ""
    fields: tuple[str, ...] = ()

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "type": self.type.to_json(),
            "doc": self.doc,
            "store": self.store,
            "fields": list(self.fields),
        }


_PY_TYPES: dict[str, tuple[type, ...]] = {
    "float": (float, int),
    "int": (int,),
    "bool": (bool,),
    "str": (str,),
    "path": (str,),
    "mapping": (dict,),
}


def is_zarr_store(path: str) -> bool:
    """True for a folder that is a Zarr store (v3 ``zarr.json`` or v2 ``.zgroup``): a path
    parameter may name one (a gridded truth, a CfRadial 2 volume)."""
    return any(os.path.isfile(os.path.join(path, n)) for n in ("zarr.json", ".zgroup"))


@dataclass(frozen=True)
class Param:
    """A block parameter: type, default, unit, bounds and a one-line doc.

    Parameters
    ----------
    default : object
        Value used when the graph file gives none; ``None`` means the parameter is required,
        unless ``optional`` is set (then ``None`` means "not given": the block decides).
    type : {"float", "int", "bool", "str", "path", "mapping"}
        Value type; ``int`` values are accepted for ``float`` parameters. A ``mapping`` is
        a text-to-text mapping (``{DBZH: DBZHC}`` in a graph file).
    units : str
        Unit of the value; the name of the parameter carries it too (``gain_db``).
    min, max : float, optional
        Inclusive bounds.
    choices : tuple, optional
        The allowed values, for enumerations; for a ``mapping``, its allowed keys.
    doc : str
        One line shown by ``pasim blocks`` and the editor.
    optional : bool
        The parameter may be left unset (``None``).
    """

    default: Any = None
    type: str = "float"
    units: str = ""
    min: float | None = None
    max: float | None = None
    choices: tuple[Any, ...] | None = None
    doc: str = ""
    optional: bool = False
    name: str = field(default="")

    @property
    def required(self) -> bool:
        return self.default is None and not self.optional

    def check(self, value: Any) -> str | None:
        """Return what is wrong with ``value``, or ``None`` when it is acceptable."""
        kinds: tuple[type, ...] = _PY_TYPES[self.type]
        if value is None and self.optional:
            return None
        if isinstance(value, bool) and self.type != "bool":
            return f"expected {self.type}, found bool {value!r}"
        if not isinstance(value, kinds):
            return f"expected {self.type}, found {type(value).__name__} {value!r}"
        value = cast(Any, value)  # isinstance on a runtime tuple narrows to object
        if self.type == "mapping":
            return _mapping_problem(value, self.choices)
        if self.type == "float" and not math.isfinite(float(value)):
            return f"expected a finite number, found {value!r}"
        if self.type == "path" and value:
            if not os.path.exists(value):
                return f"expected an existing file, found {value!r} (no such file)"
            if os.path.isdir(value) and not is_zarr_store(value):
                return f"expected a file, found {value!r}, which is a directory"
            if not os.access(value, os.R_OK):
                return f"expected a readable file, found {value!r} (permission denied)"
        if self.choices is not None and value not in self.choices:
            allowed = ", ".join(repr(c) for c in self.choices)
            return f"expected one of {allowed}, found {value!r}"
        if self.min is not None and value < self.min:
            return f"expected >= {self.min}{_unit(self.units)}, found {value!r}"
        if self.max is not None and value > self.max:
            return f"expected <= {self.max}{_unit(self.units)}, found {value!r}"
        return None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "name": self.name,
            "type": self.type,
            "default": self.default,
            "units": self.units,
            "doc": self.doc,
            "required": self.required,
        }
        if self.min is not None:
            out["minimum"] = self.min
        if self.max is not None:
            out["maximum"] = self.max
        if self.choices is not None:
            out["choices"] = list(self.choices)
        return out


def _mapping_problem(value: dict[Any, Any], keys: tuple[Any, ...] | None) -> str | None:
    """What is wrong with a ``mapping`` parameter's value: text to non-empty text, each key
    among ``keys`` (when given), no value given twice."""
    for key, item in value.items():
        if not isinstance(key, str) or not isinstance(item, str) or not item.strip():
            return f"expected a mapping of names to names, found {key!r}: {item!r}"
        if keys is not None and key not in keys:
            allowed = ", ".join(str(k) for k in keys)
            return f"expected keys among {allowed}, found {key!r}"
    twice = sorted({v for v in value.values() if list(value.values()).count(v) > 1})
    if twice:
        return f"expected each name once, found {twice[0]!r} for several keys"
    return None


def _unit(units: str) -> str:
    return f" {units}" if units else ""
