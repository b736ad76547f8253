"""A deliberately faulty block: it passes the moments on with DBZH misspelt DBZ.

Its ports are declared right (the library's moments port type), so the graph validates; only
what it returns at run time is wrong, and the executor must stop the run at this block.
"""

from __future__ import annotations

from typing import Any

from pasim_blocks.signals import MOMENTS

from pasim_graph import Block, Chunk, Input, Output


class MisspeltMoments(Block):
    """Passes the moments through, with the reflectivity variable misspelt (for a test)."""

    moments_in = Input(MOMENTS, doc="estimated moments")
    moments = Output(MOMENTS, doc="the same moments, DBZH renamed DBZ")

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        return {"moments": inputs["moments_in"].rename({"DBZH": "DBZ"})}
