"""Swapping a block's type: which registered types fit the block's wires, and the swap.

A type fits when each wire keeps working unchanged (:func:`fit`); the swap keeps the
parameters the new type declares and hands back the others, for the page to restore them
when the block is swapped back.
"""

from __future__ import annotations

import json
from typing import Any

from .. import registry
from ..block import Block
from ..graphfile import ConnectionSpec, GraphSpec
from .documents import RequestError, mapping, spec_from_doc, subsystem


def _wires(spec: GraphSpec, block: str) -> list[ConnectionSpec]:
    return [c for c in spec.connections if block in (c.src.block, c.dst.block)]


def fit(spec: GraphSpec, block: str, cls: type[Block]) -> list[str]:
    """Why a block of type ``cls`` would not fit the wires ``block`` has (empty: it fits).

    Each wire keeps its text: its far end resolves as before, and this block's end must name
    a port of the new type (or leave it out when the new type has exactly one on that side)
    whose type equals the far end's (``PortType.mismatch``, the engine's own comparison).
    A wire whose far end cannot be resolved (unknown type, unknown port) is left to
    validation, which reports it either way.
    """
    reasons = []
    for c in _wires(spec, block):
        if c.src.block == c.dst.block:
            continue
        mine, other = (c.dst, c.src) if c.dst.block == block else (c.src, c.dst)
        incoming = mine is c.dst
        other_spec = spec.blocks.get(other.block)
        other_cls = registry.get(other_spec.type) if other_spec else None
        if other_cls is None:
            continue
        far_ports = other_cls.outputs if incoming else other_cls.inputs
        far = other.port_in(far_ports)
        if far is None:
            continue
        near_ports = cls.inputs if incoming else cls.outputs
        side = "input" if incoming else "output"
        near = mine.port_in(near_ports)
        if near is None:
            listed = ", ".join(near_ports) or "none"
            if mine.port is None:
                reasons.append(
                    f"the wire '{c}' leaves out the {side} port, and {cls.type_name} has "
                    f"{len(near_ports)} {side}s ({listed}), not exactly one"
                )
            else:
                reasons.append(
                    f"the wire '{c}' needs an {side} '{mine.port}', and {cls.type_name} has "
                    f"none ({side}s: {listed})"
                )
            continue
        out_t = other_cls.outputs[far].type if incoming else cls.outputs[near].type
        in_t = cls.inputs[near].type if incoming else other_cls.inputs[far].type
        diff = out_t.mismatch(in_t)
        if diff:
            mine_t, far_t = (in_t, out_t) if incoming else (out_t, in_t)
            reasons.append(
                f"the wire '{c}' carries {far_t.describe()}, and the {side} '{near}' of "
                f"{cls.type_name} is {mine_t.describe()} ({'; '.join(diff)})"
            )
    return reasons


def swap_options(doc: Any, block: str) -> dict[str, Any]:
    """Every registered type as a candidate for ``block``: whether it fits, and why not."""
    spec = spec_from_doc(doc)
    if block not in spec.blocks:
        raise RequestError(404, f"no block named {block!r} in the graph")
    current = spec.blocks[block]
    into = [c.dst for c in _wires(spec, block) if c.dst.block == block]
    options = []
    for name, cls in registry.all_blocks().items():
        if name == current.type:
            continue
        reasons = fit(spec, block, cls)
        connected = {end.port_in(cls.inputs) for end in into}
        unwired = [p.name for p in cls.inputs.values() if p.required and p.name not in connected]
        options.append(
            {
                "type": name,
                "group": subsystem(name),
                "doc": cls.doc(),
                "fits": not reasons,
                "reasons": reasons,
                "drops": sorted(k for k in current.params if k not in cls.params),
                "needs_wiring": unwired,
            }
        )
    # Same subsystem first, then whatever fits, then the rest by name.
    mine = subsystem(current.type)
    options.sort(key=lambda o: (o["group"] != mine, not o["fits"], o["type"]))
    return {"block": block, "current": current.type, "options": options}


def swap(doc: Any, block: str, new_type: Any, stash: Any = None) -> dict[str, Any]:
    """Change ``block`` to ``new_type`` if it fits the block's wires.

    Parameters
    ----------
    doc : dict
        The document (not changed).
    block : str
        The block to swap.
    new_type : str
        A registered block type.
    stash : dict, optional
        Parameters (name -> value text) dropped by earlier swaps of this block; those the
        new type declares come back, so that a swap there and back restores the block.

    Returns
    -------
    dict
        ``doc``: the new document; ``dropped``: the parameters the new type does not
        declare (name -> value text), for the page to name and keep; ``restored``: the
        parameters taken back from ``stash``.

    Raises
    ------
    RequestError
        409 with every reason when the new type does not fit; 400 or 404 when the type or
        the block is unknown.
    """
    spec = spec_from_doc(doc)
    if block not in spec.blocks:
        raise RequestError(404, f"no block named {block!r} in the graph")
    if not isinstance(new_type, str) or not new_type:
        raise RequestError(400, "expected 'type': the block type to swap to")
    cls = registry.get(new_type)
    if cls is None:
        err = registry.load_error(new_type)
        why = f"failed to load: {err}" if err else "is not a registered block type"
        raise RequestError(400, f"cannot swap '{block}' to {new_type!r}: it {why}")
    reasons = fit(spec, block, cls)
    if reasons:
        raise RequestError(
            409,
            f"cannot swap '{block}' to {new_type}: its ports do not fit the block's wires: "
            + "; ".join(reasons),
            reasons=reasons,
        )
    old = doc["blocks"][block]
    params = dict(old.get("params") or {})
    stash = {k: v for k, v in mapping(stash, "'stash'").items() if isinstance(v, str)}
    dropped = {k: v for k, v in params.items() if k not in cls.params}
    restored = {k: v for k, v in stash.items() if k in cls.params and k not in params}
    kept = {k: v for k, v in params.items() if k in cls.params} | restored
    new_doc = json.loads(json.dumps(doc))
    new_doc["blocks"][block] = {"type": new_type, "params": dict(sorted(kept.items()))}
    return {"doc": new_doc, "dropped": dropped, "restored": restored}
