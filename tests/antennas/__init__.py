"""Tests of blocks/antennas/ (pasim_blocks.antennas): patterns, arrays, elements, coupling,
``pasim pattern``."""
