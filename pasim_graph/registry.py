"""Registry of block types, discovered through the ``pasim_graph.blocks`` entry-point group.

Built-in blocks register through the same group as third-party plugins. The group is read
once and cached (:func:`refresh` clears the cache after installing a package mid-process).
Each block class is imported on first use; one that fails to import warns with its name and
error and does not take the others down.
"""

from __future__ import annotations

import difflib
import warnings
from functools import lru_cache
from importlib.metadata import EntryPoint, entry_points
from typing import Any

from .block import TYPE_NAMES, Block
from .contracts import Command, abstract_methods, command_problems

GROUP = "pasim_graph.blocks"
#: Entry-point group of command-line subcommands from plugin packages (``pasim waveform``).
COMMANDS = "pasim_graph.commands"
#: Entry-point group of a finished run's pictures: each names a callable
#: ``(sweep, scores, dpi) -> ([(name, png bytes), ...], [note, ...])`` (the studio draws them).
FIGURES = "pasim_graph.figures"


class PluginWarning(RuntimeWarning):
    """A block plugin could not be loaded."""


@lru_cache(maxsize=1)
def _entry_points() -> dict[str, EntryPoint]:
    found: dict[str, EntryPoint] = {}
    # Sorted so that, when two packages claim one name, the same one wins every time.
    for ep in sorted(entry_points(group=GROUP), key=lambda e: (e.name, e.value)):
        if ep.name in found and found[ep.name].value != ep.value:
            warnings.warn(
                f"block type {ep.name!r} is registered twice ({found[ep.name].value} and "
                f"{ep.value}); using {found[ep.name].value}",
                PluginWarning,
                stacklevel=2,
            )
            continue
        found[ep.name] = ep
    return found


_loaded: dict[str, type[Block] | None] = {}
_errors: dict[str, str] = {}


def interrupted(exc: BaseException) -> None:
    """Raise KeyboardInterrupt when ``exc`` came of one: Ctrl-C while a compiled module
    initialises reaches here as that module's ImportError (pybind11's "initialization
    failed", raised from the interrupt), and was reported as a broken block type (with every
    graph problem that followed) instead of the interrupt it is."""
    seen: set[int] = set()
    cause: BaseException | None = exc
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            raise KeyboardInterrupt from exc
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__


def refresh() -> None:
    """Forget what was discovered, e.g. after installing a plugin package."""
    _entry_points.cache_clear()
    commands.cache_clear()
    _loaded.clear()
    _errors.clear()


def names() -> list[str]:
    """Every registered block type name, loadable or not, sorted."""
    return sorted(_entry_points())


def load_error(name: str) -> str | None:
    """Why a registered block type failed to load, if it did."""
    get(name)
    return _errors.get(name)


def get(name: str) -> type[Block] | None:
    """The block class registered as ``name``, or ``None`` if unknown or broken."""
    if name in _loaded:
        return _loaded[name]
    ep = _entry_points().get(name)
    cls: type[Block] | None = None
    if ep is not None:
        try:
            obj = ep.load()
            if not (isinstance(obj, type) and issubclass(obj, Block)):
                raise TypeError(f"{ep.value} is not a pasim_graph.Block subclass")
            missing = abstract_methods(obj)
            if missing:
                # A block written against a declared base (an antenna, ...) that leaves out
                # one of its methods is refused here, naming the method, not at its first use.
                raise TypeError(f"{ep.value} does not define {missing}")
            cls = obj
            # The first name a class is loaded under stays its name: a plugin that registers
            # a library class under a second name does not rename the library's class.
            TYPE_NAMES.setdefault(cls, name)
        except Exception as exc:  # a broken plugin must not break everyone else
            interrupted(exc)
            _errors[name] = f"{type(exc).__name__}: {exc}"
            warnings.warn(
                f"block plugin {name!r} ({ep.value}) failed to load: {_errors[name]}",
                PluginWarning,
                stacklevel=2,
            )
    _loaded[name] = cls
    return cls


def all_blocks() -> dict[str, type[Block]]:
    """Every block type that loads, by name (broken plugins warn and are left out)."""
    out = {}
    for name in names():
        cls = get(name)
        if cls is not None:
            out[name] = cls
    return out


def closest(name: str, n: int = 3) -> list[str]:
    return difflib.get_close_matches(name, names(), n=n, cutoff=0.5)


@lru_cache(maxsize=1)
def commands() -> dict[str, Command]:
    """Subcommands registered by packages, by name: each a
    :class:`~pasim_graph.command_api.Command`; one that fails to load or is not a command
    warns, naming what it lacks, and is left out."""
    out: dict[str, Command] = {}
    for ep in sorted(entry_points(group=COMMANDS), key=lambda e: (e.name, e.value)):
        if ep.name in out:
            continue
        try:
            command = ep.load()
            problems = command_problems(command)
            if problems:
                raise TypeError(f"{ep.value} is not a pasim command: {'; '.join(problems)}")
        except Exception as exc:  # a broken plugin must not break the command line
            interrupted(exc)
            warnings.warn(
                f"command plugin {ep.name!r} ({ep.value}) failed to load: "
                f"{type(exc).__name__}: {exc}",
                PluginWarning,
                stacklevel=2,
            )
            continue
        out[ep.name] = command
    return out


def figure_makers() -> dict[str, Any]:
    """Run-picture makers registered by packages (:data:`FIGURES`), by name.

    The engine knows no radar moments; the block library registers the PPIs of truth,
    estimate and error. One that fails to load warns and is left out.
    """
    out: dict[str, Any] = {}
    for ep in sorted(entry_points(group=FIGURES), key=lambda e: (e.name, e.value)):
        if ep.name in out:
            continue
        try:
            make = ep.load()
            if not callable(make):
                raise TypeError(f"{ep.value} is not callable")
        except Exception as exc:  # a broken plugin must not break the studio
            interrupted(exc)
            warnings.warn(
                f"figure plugin {ep.name!r} ({ep.value}) failed to load: "
                f"{type(exc).__name__}: {exc}",
                PluginWarning,
                stacklevel=2,
            )
            continue
        out[ep.name] = make
    return out
