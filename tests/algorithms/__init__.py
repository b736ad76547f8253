"""Tests of blocks/algorithms/ (pasim_blocks.algorithms): the Py-ART algorithm blocks, their
products in runs and studies."""
