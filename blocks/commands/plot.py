"""``pasim plot STORE``: truth, estimate and error of each moment of a run as PPIs."""

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

    def run(self, args: argparse.Namespace) -> int:
        from pasim_graph.cli import UserError

        from ..products.plot import NotAStoreError, plot_store

        store = Path(args.store)
        out = Path(args.out) if args.out else Path(store.name.removesuffix(".zarr") + ".png")
        fields = [f.strip() for f in args.fields.split(",") if f.strip()] if args.fields else None
        try:
            notes = plot_store(store, out, fields)
        except (NotAStoreError, ValueError) as exc:
            raise UserError(str(exc)) from None
        for note in notes:
            print(f"note: {note}", file=sys.stderr)
        print(f"wrote {out}", file=sys.stderr)
        return 0


COMMAND = PlotCommand()
