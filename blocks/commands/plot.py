"""``pasim plot STORE``: truth, estimate and error of each moment of a run as PPIs, or
range-height pictures for an RHI."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


class PlotCommand:
    """The ``pasim plot`` subcommand (registered as a ``pasim_graph.commands`` plugin)."""

    help = "truth, estimate and error of each moment of a run as PPIs"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("store")
        parser.add_argument(
            "--fields", metavar="FIELD[,FIELD...]", help="moments to draw (default: all)"
        )
        parser.add_argument("--out", metavar="FILE.png", help="default: the store's name with .png")
        parser.add_argument(
            "--sweep",
            type=int,
            default=0,
            metavar="N",
            help="which sweep of a volume to draw (default 0); an RHI is drawn range-height",
        )

    def run(self, args: argparse.Namespace) -> int:
        from pasim_graph.command_api import UserError

        from ..products.plot import NotAStoreError, plot_store

        store = Path(args.store)
        out = Path(args.out) if args.out else Path(store.name.removesuffix(".zarr") + ".png")
        fields = [f.strip() for f in args.fields.split(",") if f.strip()] if args.fields else None
        try:
            notes = plot_store(store, out, fields, sweep_index=args.sweep)
        except (NotAStoreError, ValueError) as exc:
            raise UserError(str(exc)) from None
        for note in notes:
            print(f"note: {note}", file=sys.stderr)
        print(f"wrote {out}", file=sys.stderr)
        return 0


COMMAND = PlotCommand()
