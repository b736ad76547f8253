"""The FM-301 / CfRadial 2 global attributes that say what made a store: the instrument
(the simulated system), the program, the paper it implements, and the command that ran it."""

from __future__ import annotations

import datetime as dt
from typing import Any

from . import __version__

#: The paper PASIM-graph implements.
REFERENCE = (
    "Li et al., 2019: Phased-Array Radar System Simulator (PASIM): Development and "
    "Simulation Result Assessment. Remote Sensing"
)


def provenance(instrument: str, command: str, now: dt.datetime | None = None) -> dict[str, Any]:
    """FM-301's ``instrument_name`` (the simulated system: graph or study system name),
    ``institution``, ``references``, ``comment``, ``history`` (UTC time and ``command``)
    and ``platform_is_mobile`` ("false": a simulated ground radar)."""
    when = (now or dt.datetime.now(dt.timezone.utc)).strftime("%Y-%m-%dT%H:%M:%SZ")
    return {
        "instrument_name": instrument,
        "institution": "PASIM-graph, an open-source phased-array weather radar simulator",
        "references": REFERENCE,
        "comment": (
            "simulated volume: the moments are estimates from simulated signals; truth_* "
            "holds the scene they were simulated from"
        ),
        "history": f"{when}: {command} (pasim-graph {__version__})",
        "platform_is_mobile": "false",
    }


def run_attrs(graph_text: str, graph_file: str, instrument: str, command: str) -> dict[str, Any]:
    """The root attributes every simulated store starts from (``pasim run`` and each run of a
    study add their own): what wrote it, the graph as run, and :func:`provenance`."""
    return {
        "title": "PASIM-graph simulated radar volume",
        "Conventions": "Cf/Radial",
        "version": "2.0",
        "pasim_graph_version": __version__,
        "graph": graph_text,
        "graph_file": graph_file,
        "simulated": "true",
        "source": "PASIM-graph simulation",
        **provenance(instrument, command),
    }
