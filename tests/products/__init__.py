"""Tests of blocks/products/ (pasim_blocks.products): figures of a run and its export to other
formats."""
