"""The pairs two runs of one study rank, side by side (run by hand, not in CI).

    python benchmarks/compare_seed_rankings.py ONE_SEED_DIR THREE_SEED_DIR [--case convective]

Reads each folder's ``scores.json`` (``_study.pairs``) and prints, for every moment and pair of
systems, the paired difference (first name minus second, alphabetical), whether it ranks and
which interval separated it, and the paired over unpaired width, in both studies; then counts
the pairs ranked alike, ranked in one study only, and ranked in opposite directions. The
three-seed folder can be the one-seed one with seeds added (``pasim study --resume``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def pairs(folder: Path, case: str) -> dict[tuple[str, str, str], dict]:
    scores = json.loads((folder / "scores.json").read_text())
    out = {}
    for field, rows in scores["_study"]["pairs"][case].items():
        for r in rows:
            a, b = sorted((r["a"], r["b"]))
            sign = 1 if r["a"] == a else -1
            out[(field, a, b)] = {**r, "difference": sign * r["difference"]}
    return out


def cell(r: dict) -> str:
    how = "+".join(r["separated_by"]) or "none"
    return (
        f"{r['difference']:+.4g} | {'ranked' if r['ranked'] else 'unranked'} ({how}) | "
        f"{r['paired_over_unpaired']:.3f}"
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("one", type=Path)
    ap.add_argument("three", type=Path)
    ap.add_argument("--case", default="convective")
    args = ap.parse_args()
    one, three = pairs(args.one, args.case), pairs(args.three, args.case)
    print(
        "| moment | pair (a - b) | one seed: difference | verdict (separated by) | paired/unpaired "
        "| three seeds: difference | verdict (separated by) | paired/unpaired |"
    )
    print("|---|---|---|---|---|---|---|---|")
    alike = only = opposite = 0
    for key in one:
        p1, p3 = one[key], three[key]
        print(f"| {key[0]} | {key[1]} - {key[2]} | {cell(p1)} | {cell(p3)} |")
        if p1["ranked"] and p3["ranked"]:
            same = (p1["difference"] > 0) == (p3["difference"] > 0)
            alike += same
            opposite += not same
        elif p1["ranked"] or p3["ranked"]:
            only += 1
        else:
            alike += 1
    print(
        f"\n{len(one)} pairs: {alike} alike (ranked the same way or unranked in both), "
        f"{only} ranked in one study only, {opposite} ranked in opposite directions"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
