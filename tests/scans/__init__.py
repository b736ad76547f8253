"""Tests of blocks/scans/ (pasim_blocks.scans): which beams, when, and from where."""
