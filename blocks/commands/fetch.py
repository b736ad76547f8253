"""``pasim fetch RADAR TIME``: the NEXRAD Level-II volume nearest a time, from the public
archive, cached locally; prints its path (use it as ``--truth``)."""

from __future__ import annotations

import argparse
from pathlib import Path


class FetchCommand:
    """The ``pasim fetch`` subcommand (registered as a ``pasim_graph.commands`` plugin)."""

    help = "download the NEXRAD Level-II volume nearest a time from the public archive"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("radar", metavar="RADAR", help="four-letter site, e.g. KTLX")
        parser.add_argument("time", metavar="TIME", help="UTC time, e.g. 2013-05-20T20:08Z")
        parser.add_argument(
            "--cache",
            metavar="DIR",
            default=str(Path.home() / ".cache" / "pasim" / "nexrad"),
            help="where volumes are kept (default ~/.cache/pasim/nexrad)",
        )

    def run(self, args: argparse.Namespace) -> int:
        from pasim_graph.command_api import UserError

        from ..truth.archive import ArchiveError, fetch, parse_time

        try:
            when = parse_time(args.time)
            path = fetch(args.radar.upper(), when, Path(args.cache))
        except (ValueError, ArchiveError) as exc:
            raise UserError(f"fetch {args.radar} {args.time}: {exc}") from None
        except OSError as exc:
            raise UserError(
                f"fetch {args.radar} {args.time}: --cache {args.cache}: {exc}"
            ) from None
        print(path)
        return 0


COMMAND = FetchCommand()
