"""Typed ports and parameters, declared on a block class.

A port type is a signal kind plus dtype, dimensions and units; two ports connect only when
all four agree. A parameter declares its type, default, unit, bounds and a one-line doc once,
and that declaration drives validation, the command line and the JSON interface.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any, cast

#: The dimension along which an executor splits a scan into chunks. A port whose type has it
#: carries one chunk of beams; a port without it carries data shared by every chunk.
BEAM_DIM = "beam"

#: dtype of a port that carries an ``xarray.Dataset`` (a bundle of named, labelled arrays).
DATASET = "dataset"


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
    """

    kind: str
    dtype: str
    dims: tuple[str, ...] = ()
    units: str = "1"

    @property
    def per_beam(self) -> bool:
        """True when the data is split over beams (one chunk at a time)."""
        return BEAM_DIM in self.dims

    def mismatch(self, other: PortType) -> list[str]:
        """Describe each way ``other`` differs from this type (empty when compatible)."""
        out = []
        for name in ("kind", "dtype", "dims", "units"):
            a, b = getattr(self, name), getattr(other, name)
            if a != b:
                out.append(f"{name} {_fmt(a)} vs {_fmt(b)}")
        return out

    def describe(self) -> str:
        dims = ", ".join(self.dims)
        return f"{self.kind}[{self.dtype}; ({dims}); {self.units}]"

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "dtype": self.dtype,
            "dims": list(self.dims),
            "units": self.units,
        }


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
}


@dataclass(frozen=True)
class Param:
    """A block parameter: type, default, unit, bounds and a one-line doc.

    Parameters
    ----------
    default : object
        Value used when the graph file gives none; ``None`` means the parameter is required,
        unless ``optional`` is set (then ``None`` means "not given": the block decides).
    type : {"float", "int", "bool", "str", "path"}
        Value type; ``int`` values are accepted for ``float`` parameters.
    units : str
        Unit of the value; the name of the parameter carries it too (``gain_db``).
    min, max : float, optional
        Inclusive bounds.
    choices : tuple, optional
        The allowed values, for enumerations.
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
        if self.type == "float" and not math.isfinite(float(value)):
            return f"expected a finite number, found {value!r}"
        if self.type == "path" and value and not os.path.exists(value):
            return f"expected an existing file, found {value!r} (no such file)"
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


def _unit(units: str) -> str:
    return f" {units}" if units else ""
