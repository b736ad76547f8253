"""What a ``pasim`` subcommand of a plugin package is and may use.

A package adds a subcommand by naming an object in the ``pasim_graph.commands`` entry-point
group (the block library's ``pasim pattern``, ``waveform``, ``spectrum``, ``study`` come this
way). The object meets :class:`Command` (declared in :mod:`.contracts`, re-exported here); the
registry checks it when it loads it and leaves out, with one warning naming what is missing,
one that does not. A command reads its graph
with :func:`add_graph_arguments` and :func:`load_graph`, takes a run seed with
:func:`parse_seed`, and raises :class:`UserError` for anything the user can fix: ``pasim``
prints it as one line and exits 2, never with a traceback.

This module is the whole of the command line a plugin imports; ``pasim_graph.cli`` is the
program itself and may change.
"""

from __future__ import annotations

import argparse
from typing import Any

from .contracts import Command, command_problems
from .graph import Graph, resolve

__all__ = [
    "OPTIONS",
    "Command",
    "UserError",
    "add_graph_arguments",
    "command_problems",
    "graph_and_overrides",
    "load_graph",
    "parse_seed",
]

#: The options that :func:`pasim_graph.graph.resolve` names in its problems.
OPTIONS = {"set": "--set", "truth": "--truth", "sector": "--sector"}


class UserError(Exception):
    """A problem the user can fix; printed without a traceback."""


def add_graph_arguments(parser: argparse.ArgumentParser) -> None:
    """The options that change a graph as it is read: ``--truth``, ``--sector``, ``--set``.

    A command that adds them gets its graph with :func:`load_graph`.
    """
    parser.add_argument(
        "--truth",
        metavar="FILE",
        help="truth file for the truth block: NEXRAD Level-II, or a radar file xradar reads "
        "(CfRadial 1, a CfRadial 2 Zarr store, ODIM_H5, GAMIC, IRIS/Sigmet, UF, Rainbow, "
        "Furuno); for truth.grid a gridded netCDF file or Zarr store",
    )
    parser.add_argument(
        "--sector",
        metavar="AZ0:AZ1",
        help="azimuth sector in degrees clockwise for the scan block, e.g. 240:330; 350:10 "
        "(or -10:10) passes through north, 0:360 is the full circle",
    )
    parser.add_argument(
        "--set",
        action="append",
        metavar="BLOCK.PARAM=VALUE",
        help="override a block parameter (repeatable)",
    )


def graph_and_overrides(args: argparse.Namespace) -> tuple[Graph, dict[str, Any]]:
    """The validated graph of ``args.graph`` and the overrides (``--set``, ``--truth``,
    ``--sector``) it got (raises GraphError, which ``pasim`` prints as its report)."""
    return resolve(
        args.graph,
        settings=getattr(args, "set", None) or [],
        truth=getattr(args, "truth", None),
        sector=getattr(args, "sector", None),
        labels=OPTIONS,
    )


def load_graph(args: argparse.Namespace) -> Graph:
    """The validated graph of a command's arguments (raises GraphError, printed as usual)."""
    return graph_and_overrides(args)[0]


def parse_seed(text: str) -> int:
    """argparse type of a run seed (a whole number >= 0)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, found {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(
            f"the seed must be a whole number >= 0 (random streams are keyed by it), found {value}"
        )
    return value
