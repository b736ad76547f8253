"""The block base class and the context a block sees while it processes one chunk."""

from __future__ import annotations

import inspect
import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from .ports import DATASET, Input, Output, Param


class RunNote(UserWarning):
    """Something a user should know about a run that is not an error.

    Blocks raise it with ``warnings.warn(message, RunNote)`` (e.g. a truth without
    polarimetric fields runs as single polarisation); the command line prints each one once as
    ``note: ...``.
    """


@dataclass(frozen=True)
class Chunk:
    """One chunk of beams as handed to :meth:`Block.process`.

    Attributes
    ----------
    beams : numpy.ndarray
        Indices (into the whole scan) of the beams in this chunk, in scan order.
    seed : int
        The run seed.
    block_name : str
        Name of the block in the graph; keys its random streams.
    resource : object
        What the block's :meth:`Block.load` returned (the executor did the I/O).
    options : mapping
        Run options a block may read (``save_iq``; ``fields``: the output fields asked for,
        None for all; see :meth:`wants`).
    sweep : int
        Index of the sweep of a volume the beams belong to (0 for a one-sweep scan).
    expected : bool
        True when a block of the graph that declares a fidelity parameter
        (:attr:`Block.fidelity_param`) runs at its declared :attr:`Block.expected_level`, so
        no time series are drawn (the weather channel's ``method: expected``: the I/Q cube's
        pulse axis has length 0 and the expected correlations stand for it). The executor
        sets it once per run from the block classes' declarations and the graph's parameter
        values (:meth:`Graph.at_expected_level`); blocks downstream decide on it, never on an
        axis's length. False (time series drawn) when a chunk is built without it.
    """

    beams: np.ndarray
    seed: int = 0
    block_name: str = ""
    resource: Any = None
    options: Mapping[str, Any] = field(default_factory=dict)
    sweep: int = 0
    expected: bool = False

    def rng(self, beam: int, *stream: int) -> np.random.Generator:
        """Random generator for one beam, from the run seed, the block name, the sweep and the
        beam index.

        Streams are per beam so that the numbers do not depend on how beams are chunked or on
        which worker runs them. Extra integers select independent sub-streams, so that a part
        of the work can be skipped without changing the numbers of the rest (a block that
        draws H from ``rng(beam)`` and V from ``rng(beam, 1)`` gives the same H when it is
        asked for H only).
        """
        # Each sweep of a volume draws its own streams (beam indices restart at 0 in each);
        # the first sweep's are those of a one-sweep scan.
        name = self.block_name if not self.sweep else f"{self.block_name}#sweep{self.sweep}"
        key = zlib.crc32(name.encode())
        entropy = [self.seed, key, int(beam), *(int(s) for s in stream)]
        return np.random.default_rng(np.random.SeedSequence(entropy))

    def wants(self, *fields: str) -> bool:
        """True when the run asked for any of ``fields`` (or for every field).

        Blocks use it to skip work nobody will read: ``--outputs DBZH`` makes the weather
        channel skip the V channel and the processor skip the Doppler moments.
        """
        asked = self.options.get("fields")
        return asked is None or any(f in asked for f in fields)


#: Block class -> the type name the registry first loaded it under (the registry fills it).
TYPE_NAMES: dict[type, str] = {}


class TypeName:
    """``Block.type_name``: a class's registered name, looked up in :data:`TYPE_NAMES`."""

    def __get__(self, obj: Any, cls: type) -> str:
        if obj is not None and "type_name" in vars(obj):
            return str(vars(obj)["type_name"])
        return TYPE_NAMES.get(cls, "")


class Block:
    """Base class of every block.

    A subclass declares its interface as class attributes: :class:`Input` and :class:`Output`
    ports and :class:`Param` parameters, each named after its attribute. The interface is
    readable from the class alone (``Block.interface()``), without building a block.

    ``process(inputs, chunk)`` is pure and works on one chunk: it gets a dict of input values by
    port name and returns a dict of output values by port name. It does no file I/O and uses no
    dask; a block that needs a file declares it in :meth:`load`, which the executor calls once.
    A block whose inputs and outputs carry no ``beam`` dimension runs once per run, and its
    outputs are shared by every chunk.
    """

    #: Registered type name, e.g. ``"antenna.pencil"``: the first name the registry loaded the
    #: class under, read from the registry's own table (:data:`TYPE_NAMES`), never written on
    #: the class, so registering a class under a second name does not rename it. A graph's
    #: blocks carry the name their graph gave them. Unregistered classes may set it.
    type_name: ClassVar[str] = TypeName()  # type: ignore[assignment]
    #: Set on the block that defines the beams of a scan (exactly one per graph).
    beam_source: ClassVar[bool] = False
    #: Set on a block that runs once per sweep, on the whole sweep, after the sweep's chunks
    #: are written (an algorithm that needs neighbouring radials): :mod:`.sweep_stage`.
    sweep_level: ClassVar[bool] = False
    #: Roles the command line can address: ``"truth"`` (``--truth``), ``"scan"`` (``--sector``).
    role: ClassVar[str] = ""

    #: Settings that trade speed for accuracy, as (label, parameter values) pairs, fastest
    #: first and most faithful last. ``pasim tradeoff`` runs a graph at each of them.
    fidelity_ladder: ClassVar[tuple[tuple[str, dict[str, Any]], ...]] = ()
    #: The parameter that chooses the block's fidelity level (``""``: the block has none), and
    #: the one of its choices that computes expected values, drawing no noise (``""``: none).
    #: A study's reference runs set every block that declares ``expected_level`` to it.
    fidelity_param: ClassVar[str] = ""
    expected_level: ClassVar[str] = ""

    #: Attributes that only memoise derived data: dropped when a block is pickled (sent to a
    #: worker), and rebuilt there on first use.
    transient: ClassVar[tuple[str, ...]] = ()

    inputs: ClassVar[dict[str, Input]] = {}
    outputs: ClassVar[dict[str, Output]] = {}
    params: ClassVar[dict[str, Param]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        inputs: dict[str, Input] = {}
        outputs: dict[str, Output] = {}
        params: dict[str, Param] = {}
        # Walk the MRO so a subclass inherits and may override its parents' declarations.
        for klass in reversed(cls.__mro__):
            for attr, value in vars(klass).items():
                if isinstance(value, Input):
                    inputs[attr] = _named(value, attr)
                elif isinstance(value, Output):
                    outputs[attr] = _named(value, attr)
                elif isinstance(value, Param):
                    params[attr] = _named(value, attr)
        cls.inputs, cls.outputs, cls.params = inputs, outputs, params

    def __init__(self, name: str = "", **params: Any) -> None:
        self.name = name
        values = {k: p.default for k, p in self.params.items()}
        values.update(params)
        problems = [f"unknown parameter {k!r}" for k in sorted(set(params) - set(self.params))]
        for key, value in params.items():
            decl = self.params.get(key)
            if decl is not None and decl.type == "float" and type(value) is int:
                values[key] = float(value)
            err = decl.check(values[key]) if decl is not None else None
            if err:
                problems.append(f"parameter {key!r}: {err}")
        problems += [
            f"parameter {k!r}: required"
            for k, d in self.params.items()
            if d.required and values[k] is None
        ]
        if problems:
            raise ValueError(f"{type(self).__name__} {name!r}: " + "; ".join(problems))
        self.p: dict[str, Any] = values
        self.setup()

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        """Problems with a combination of parameters and connections, checked at validation.

        ``params`` holds the valid values given in the graph (defaults not filled in),
        ``connected`` the names of the connected inputs. Return ``(item, message)`` pairs,
        e.g. ``("parameter 'snr_db'", "needs the input 'signal_power' connected")``.
        """
        return []

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        for name in self.transient:
            state.pop(name, None)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        for name in self.transient:
            self.__dict__.setdefault(name, None)

    @classmethod
    def warm_up(cls) -> None:
        """Import what the block imports lazily; a worker calls it before its first chunk."""

    def setup(self) -> None:
        """Derive state from the parameters (no I/O); called once when the block is built."""

    def load(self) -> Any:
        """Do the block's file I/O, once per run; the result reaches :meth:`process`."""
        return None

    def beam_count(self) -> int:
        """Number of beams in the scan (beam sources only)."""
        raise NotImplementedError

    @classmethod
    def scan_sweeps(cls, params: dict[str, Any]) -> list[dict[str, Any]]:
        """The sweeps of a scan (beam sources only): one dict of this block's parameter
        overrides per sweep, read from the class and the graph's ``params`` (defaults not
        filled in). The executor runs the graph once per sweep, the beam source built with
        that sweep's overrides, and stores each as its own FM-301 ``sweep_N`` group. The
        default is one sweep with the graph's parameters."""
        return [{}]

    @classmethod
    def steering_problems(
        cls, params: dict[str, Any], azimuth_deg: np.ndarray, elevation_deg: np.ndarray
    ) -> list[tuple[str, str]]:
        """Beams of the scan this block cannot point at (a steerable antenna's), as
        ``(item, message)`` pairs; empty when it reaches them all (the default).

        ``params`` holds the valid values given in the graph (defaults not filled in), the
        arrays the azimuth and elevation (deg) of every beam of one sweep. Validation calls it
        with the scan's nominal beams and the executor with the beams as aligned to the truth,
        before any chunk runs, so that a run or a study is refused before any work rather than
        failing on its first beam.
        """
        return []

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        raise NotImplementedError

    @classmethod
    def interface_problems(cls) -> list[tuple[str, str]]:
        """Faults in the class's own declarations, as ``(item, message)`` pairs.

        Every port that carries a Dataset declares its schema, and the fields an output offers
        to ``--outputs`` are variables of that schema.
        """
        out = []
        ports: list[Input | Output] = [*cls.inputs.values(), *cls.outputs.values()]
        for port in ports:
            side = "input" if isinstance(port, Input) else "output"
            if port.type.dtype == DATASET and port.type.schema is None:
                out.append(
                    (f"port '{port.name}'", f"{side} carries a dataset but declares no schema")
                )
        out += cls._fidelity_problems()
        for o in cls.outputs.values():
            schema = o.type.schema
            missing = [f for f in o.fields if schema is None or f not in schema.variables]
            if missing:
                out.append(
                    (
                        f"port '{o.name}'",
                        f"fields {', '.join(missing)} are not variables of its schema",
                    )
                )
        return out

    @classmethod
    def _fidelity_problems(cls) -> list[tuple[str, str]]:
        """The fidelity declaration names a parameter of the block, and the expected level is
        one of that parameter's choices."""
        if not cls.fidelity_param:
            return (
                [("expected_level", "is set but fidelity_param names no parameter")]
                if cls.expected_level
                else []
            )
        decl = cls.params.get(cls.fidelity_param)
        if decl is None:
            return [("fidelity_param", f"{cls.fidelity_param!r} is not a parameter of the block")]
        if cls.expected_level and cls.expected_level not in (decl.choices or ()):
            return [
                (
                    "expected_level",
                    f"{cls.expected_level!r} is not a choice of parameter {cls.fidelity_param!r}",
                )
            ]
        return []

    @classmethod
    def runs_per_chunk(cls) -> bool:
        """True when the block must run for every chunk of beams."""
        ports: list[Input | Output] = [*cls.inputs.values(), *cls.outputs.values()]
        return cls.beam_source or any(p.type.per_beam for p in ports)

    @classmethod
    def doc(cls) -> str:
        text = (cls.__doc__ or "").strip()
        return text.splitlines()[0] if text else ""

    @classmethod
    def interface(cls, type_name: str | None = None) -> dict[str, Any]:
        """The block's interface as JSON-ready data, read from the class alone (``type_name``:
        the name it is listed under, by default its registered one)."""
        return {
            "type": type_name or cls.type_name,
            "class": f"{cls.__module__}.{cls.__qualname__}",
            "doc": cls.doc(),
            "description": inspect.cleandoc(cls.__doc__ or ""),
            "role": cls.role,
            "beam_source": cls.beam_source,
            "sweep_level": cls.sweep_level,
            "fidelity_ladder": [{"label": k, "params": dict(v)} for k, v in cls.fidelity_ladder],
            "inputs": [p.to_json() for p in cls.inputs.values()],
            "outputs": [p.to_json() for p in cls.outputs.values()],
            "params": [p.to_json() for p in cls.params.values()],
        }


def _named(decl: Any, name: str) -> Any:
    if decl.name == name:
        return decl
    # Declarations are frozen dataclasses; a renamed copy keeps the class attribute untouched.
    return type(decl)(**{**decl.__dict__, "name": name})
