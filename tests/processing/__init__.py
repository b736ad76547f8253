"""Tests of blocks/processing/ (pasim_blocks.processing): the moment processors, their theory and
the scorer."""
