"""``pasim compare A.zarr B.zarr ...``: systems as columns on their common gates.

Also the radar side of ``pasim score STORE --against REF.zarr`` and ``--by azimuth[:BIN]``
(:meth:`CompareCommand.score`; the engine's ``pasim score`` hands those options here, so it
never imports the block library).
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from pasim_graph.serialize import json_safe

QUANTITIES = ("std", "robust_std", "bias", "count")


def _num(v: Any) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "n/a"
    if isinstance(v, int):
        return f"{v:,}"
    return f"{v:.4g}"


def _table(header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    line = lambda r: "  ".join(  # noqa: E731
        c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths, strict=True))
    )
    return "\n".join([line(header), *(line(r) for r in rows)])


class CompareCommand:
    help = "compare stores: systems as columns on their common gates (std, robust spread, bias)"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("stores", nargs="+", metavar="STORE", help="stores of `pasim run`")
        parser.add_argument("--json", action="store_true", help="print the numbers as JSON")
        parser.add_argument(
            "--sweep",
            type=int,
            metavar="N",
            help="which sweep of volume stores to compare (required when they hold several)",
        )

    def run(self, args: argparse.Namespace) -> int:
        from pasim_graph.command_api import UserError

        from ..study.compare import CompareError, compare, names, read_store

        if len(args.stores) < 2:
            raise UserError("pasim compare needs at least two stores (pasim score reads one)")
        try:
            stores = [read_store(p, args.sweep) for p in args.stores]
            result = compare(stores)
        except CompareError as exc:
            raise UserError(str(exc)) from None
        cols = names(stores)
        if args.json:
            print(json.dumps(json_safe({"stores": cols, "fields": result}), indent=2))
            return 0
        rows = []
        for name, r in result.items():
            for q in QUANTITIES:
                label = f"{name} {'gates' if q == 'count' else q}"
                rows.append([label, *(_num(s[q]) for s in r["stores"])])
            rows.append([f"{name} own gates", *(_num(s["own_count"]) for s in r["stores"])])
        print(_table(["moment", *cols], rows))
        print(
            "errors against the raw gates, on the gates every store scored "
            "(robust_std = 1.4826 x MAD); 'own gates': each store's scored gates"
        )
        return 0

    def score(self, args: argparse.Namespace) -> int:
        """``pasim score STORE [--against REF.zarr] [--by azimuth[:BIN]]``."""
        from pasim_graph.command_api import UserError

        from ..study.compare import CompareError, by_azimuth, parse_by, read_store, score_against

        try:
            store = read_store(args.store, args.sweep)
            ref = read_store(args.against, args.sweep) if args.against else None
            if args.by:
                bin_deg = parse_by(args.by)
                from ..study.compare import errors_against

                errors = errors_against(store, ref) if ref else store.errors
                rows = by_azimuth(store.azimuth, errors, bin_deg)
                return self._print_profile(rows, list(errors), args)
            assert ref is not None
            result = score_against(store, ref)
        except CompareError as exc:
            raise UserError(str(exc)) from None
        if args.json:
            print(json.dumps(json_safe(result), indent=2))
            return 0
        table_rows = [
            [
                name,
                _num(s["bias"]),
                _num(s["std"]),
                _num(s["robust_std"]),
                _num(s["count"]),
                f"{s['requirement_bias']:g}/{s['requirement_std']:g}",
                "yes" if s["pass"] else "no",
            ]
            for name, s in result.items()
        ]
        print(
            _table(["moment", "bias", "std", "robust", "count", "req bias/std", "pass"], table_rows)
        )
        print(f"errors against {args.against} on {args.store}'s scored gates")
        return 0

    def _print_profile(
        self, rows: list[dict[str, Any]], fields: list[str], args: argparse.Namespace
    ) -> int:
        if args.json:
            print(json.dumps(json_safe(rows), indent=2))
            return 0
        header = ["azimuth", "beams"]
        for f in fields:
            header += [f"{f} bias", f"{f} std", f"{f} n"]
        table = []
        for r in rows:
            line = [f"{r['azimuth']:.2f}", str(r["beams"])]
            for f in fields:
                line += [_num(r[f]["bias"]), _num(r[f]["std"]), _num(r[f]["count"])]
            table.append(line)
        print(_table(header, table))
        return 0


COMMAND = CompareCommand()
