"""Tests of blocks/propagation/ (pasim_blocks.propagation): the path at the radar's frequency."""
