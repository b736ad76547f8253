"""The block reference: every registered block's interface as text (``pasim blocks``) and as
the Markdown page docs/blocks.md, read from the declarations alone (nothing is built)."""

from __future__ import annotations

import argparse
import inspect
import json
from typing import Any

from . import registry


def cmd_blocks(args: argparse.Namespace) -> int:
    blocks = registry.all_blocks()
    if args.json:
        print(json.dumps([c.interface(n) for n, c in blocks.items()], indent=2, default=str))
    elif args.markdown:
        print(blocks_markdown(blocks), end="")
    else:
        for name, cls in blocks.items():
            print(f"{name}  ({cls.__name__}) {cls.doc()}")
            for line in interface_lines(cls):
                print(f"    {line}")
    return 0


def param_text(q: Any) -> str:
    """A parameter's default, units, bounds or choices and doc, on one line."""
    default = "required" if q.required else repr(q.default)
    units = f" {q.units}" if q.units else ""
    limits = []
    if q.choices is not None:
        word = "keys among " if q.type == "mapping" else "one of "
        limits.append(word + ", ".join(repr(c) for c in q.choices))
    if q.min is not None and q.max is not None:
        limits.append(f"{q.min:g} to {q.max:g}{units}")
    elif q.min is not None:
        limits.append(f">= {q.min:g}{units}")
    elif q.max is not None:
        limits.append(f"<= {q.max:g}{units}")
    bounds = f" ({'; '.join(limits)})" if limits else ""
    return f"{q.name} = {default}{units} {q.type}{bounds}  {q.doc}".rstrip()


def interface_lines(cls: Any) -> list[str]:
    out = []
    for p in cls.inputs.values():
        optional = "" if p.required else " (optional)"
        out.append(f"in    {p.name}: {p.type.describe()}{optional}  {p.doc}".rstrip())
        out += [f"        {line}" for line in (p.type.schema.lines() if p.type.schema else [])]
    for o in cls.outputs.values():
        stored = f" [stored: {o.store}]" if o.store else ""
        out.append(f"out   {o.name}: {o.type.describe()}{stored}  {o.doc}".rstrip())
        out += [f"        {line}" for line in (o.type.schema.lines() if o.type.schema else [])]
    out += [f"param {param_text(q)}" for q in cls.params.values()]
    return out


def blocks_markdown(blocks: dict[str, Any]) -> str:
    """The block reference (docs/blocks.md), written from the declarations alone."""
    out = [
        "# Block reference",
        "",
        "Written by `pasim blocks --markdown` from the blocks' declarations (ports, schemas, "
        "parameters); do not edit by hand.",
        "",
    ]
    for name, cls in blocks.items():
        out += [f"## `{name}`", "", inspect.cleandoc(cls.__doc__ or ""), "", "```"]
        out += interface_lines(cls)
        out += ["```", ""]
    return "\n".join(out)
