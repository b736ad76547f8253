"""The contracts a plugin meets, declared where its author reads them, checked by the registry
when it loads the plugin (a plugin that falls short is left out with one warning naming what it
lacks; everything else still loads).

- A block class (``pasim_graph.blocks`` entry points) derives from :class:`pasim_graph.Block`
  and leaves no abstract method undefined: a base class of the block library that declares
  methods with :func:`abc.abstractmethod` (the antennas' ``pasim_blocks.antennas.antenna.Antenna``)
  is a contract the registry holds its subclasses to (:func:`abstract_methods`).
- A command (``pasim_graph.commands`` entry points) is a :class:`Command`.

This module imports nothing of the engine, so that the registry and the command-line helpers
(:mod:`.command_api`) can both import it.
"""

from __future__ import annotations

import argparse
from typing import Any, Protocol, runtime_checkable


@runtime_checkable
class Command(Protocol):
    """A ``pasim`` subcommand: its one-line help, its options, and what it does.

    ``run`` returns the exit status; a problem of the user's raises
    :class:`pasim_graph.command_api.UserError`.
    """

    help: str

    def configure(self, parser: argparse.ArgumentParser) -> None: ...

    def run(self, args: argparse.Namespace) -> int: ...


@runtime_checkable
class ScoringCommand(Command, Protocol):
    """The ``compare`` command as the engine's ``pasim score`` needs it: a :class:`Command`
    that also scores one store against another (``--against REF.zarr``) or by azimuth
    (``--by azimuth[:BIN]``), with ``pasim score``'s parsed options; returns the exit status."""

    def score(self, args: argparse.Namespace) -> int: ...


#: The members of :class:`Command`, in the order a missing one is named.
COMMAND_MEMBERS = ("help", "configure", "run")


def command_problems(obj: Any) -> list[str]:
    """What keeps ``obj`` from being a :class:`Command` (empty: nothing).

    ``isinstance(obj, Command)`` answers yes or no; this names the missing members and checks
    that the two methods can be called, which the protocol check does not.
    """
    out = [f"has no {m!r}" for m in COMMAND_MEMBERS if not hasattr(obj, m)]
    if hasattr(obj, "help") and not isinstance(obj.help, str):
        out.append("'help' is not a string")
    out += [
        f"{m!r} is not callable"
        for m in ("configure", "run")
        if hasattr(obj, m) and not callable(getattr(obj, m))
    ]
    return out


def abstract_methods(cls: type) -> str:
    """The abstract methods ``cls`` leaves undefined, each with the base that declares it
    (``"fields_at (declared by pasim_blocks.antennas.antenna.Antenna)"``); empty: none."""
    names = sorted(getattr(cls, "__abstractmethods__", ()))
    out = []
    for name in names:
        owner = next(
            (
                k
                for k in reversed(cls.__mro__)
                if getattr(vars(k).get(name), "__isabstractmethod__", False)
            ),
            None,
        )
        where = f" (declared by {owner.__module__}.{owner.__qualname__})" if owner else ""
        out.append(f"{name}{where}")
    return ", ".join(out)
