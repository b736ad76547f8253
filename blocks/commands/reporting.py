"""The tail the measuring commands share (``pasim pattern``, ``waveform``, ``spectrum``):
analyse, plot when asked, print the figures as JSON or as text, each failure one line.

A command parses its options, hands :func:`report` what to call, and prints nothing itself;
the analysis lives in the package it measures (``antennas``, ``waveforms``, ``transmitters``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from pasim_graph.command_api import UserError
from pasim_graph.serialize import json_safe

R = TypeVar("R")


def metrics_text(metrics: dict[str, Any]) -> str:
    """A command's figures as aligned ``name value`` lines (``pasim waveform``, ``spectrum``)."""
    lines = []
    for key, value in metrics.items():
        if isinstance(value, float):
            value = f"{value:.4g}" if math.isfinite(value) else str(value)
        elif isinstance(value, list):
            value = ", ".join(value) or "none"
        lines.append(f"{key:28s} {value}")
    return "\n".join(lines)


def report(
    args: argparse.Namespace,
    analyse: Callable[[], R],
    figures: Callable[[R], dict[str, Any]],
    *,
    where: str,
    plot: Callable[[R, str], None] | None = None,
    errors: tuple[type[Exception], ...] = (ValueError,),
    text: Callable[[dict[str, Any]], str] = metrics_text,
) -> int:
    """Run ``analyse``; with ``args.plot`` draw its result there; print ``figures`` of it as
    JSON (``args.json``) or ``text``. An error of ``errors`` is the user's, said after
    ``where`` (the graph or block); a plot that cannot be written names ``--plot``.
    ``plot`` None: the command draws nothing here (it refused a ``--plot`` before calling)."""
    if plot is None and args.plot:
        raise UserError(f"--plot {args.plot}: this command draws no plot here")
    if args.plot and not Path(args.plot).resolve().parent.is_dir():
        # Checked before the analysis, worded as every other output in a missing folder.
        folder = Path(args.plot).parent
        raise UserError(f"--plot {args.plot}: the folder {folder} does not exist")
    try:
        result = analyse()
    except errors as exc:
        raise UserError(f"{where}: {exc}") from None
    if plot is not None and args.plot:
        try:
            plot(result, args.plot)
        except (OSError, ValueError) as exc:
            raise UserError(f"--plot {args.plot}: {exc}") from None
    data = figures(result)
    if args.json:
        print(json.dumps({k: json_safe(v) for k, v in data.items()}, indent=2))
    else:
        print(text(data))
    if args.plot:
        # On stderr: standard output holds only the figures (JSON that a script reads).
        print(f"wrote {args.plot}", file=sys.stderr)
    return 0
