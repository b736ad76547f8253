"""``pasim export STORE --format cfradial1|cfradial2|odim [--out FILE]``: a finished run as a
file other radar tools read (Py-ART, xradar, wradlib, ...), the truth carried beside the
moments; what goes in and how is :mod:`pasim_blocks.products.exchange_files`."""

from __future__ import annotations

import argparse
import sys


class ExportCommand:
    """The ``pasim export`` subcommand (registered as a ``pasim_graph.commands`` plugin)."""

    help = "write a run as CF/Radial 1, CF/Radial 2 or ODIM_H5, the truth beside the moments"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        from ..products.exchange_files import FORMATS

        parser.add_argument("store", help="a finished store of `pasim run`")
        parser.add_argument(
            "--format",
            required=True,
            metavar="FORMAT",
            help="; ".join(f"{name}: {what}" for name, (what, _) in FORMATS.items()),
        )
        parser.add_argument(
            "--out",
            metavar="FILE",
            help="the file to write (must not exist; default: the store's name with the "
            "format, e.g. run_odim.h5, in the current folder)",
        )

    def run(self, args: argparse.Namespace) -> int:
        from pasim_graph.command_api import UserError

        from ..products.exchange_files import ExportError, export_store

        try:
            done = export_store(args.store, args.format, args.out)
        except ExportError as exc:
            raise UserError(str(exc)) from None
        print(
            f"wrote {done.path}: {len(done.sweeps)} sweep(s), fields {', '.join(done.fields)}",
            file=sys.stderr,
        )
        return 0


COMMAND = ExportCommand()
