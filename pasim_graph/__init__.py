"""PASIM-graph: a dataflow engine of typed signal blocks for phased-array weather radar simulation.

The engine (this package) knows blocks, ports, graphs, validation, plugins and executors; the
radar physics lives in the block library (``pasim_blocks``) and in plugin packages.
"""

from .block import Block, Chunk, RunNote
from .graph import Graph, GraphError, load, validate
from .ports import BEAM_DIM, DATASET, Attr, Input, Output, Param, PortType, Schema, Var

__version__ = "0.1.0"

__all__ = [
    "BEAM_DIM",
    "DATASET",
    "Attr",
    "Block",
    "Chunk",
    "Graph",
    "GraphError",
    "Input",
    "Output",
    "Param",
    "PortType",
    "RunNote",
    "Schema",
    "Var",
    "__version__",
    "load",
    "validate",
]
