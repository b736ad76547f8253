"""Tests of blocks/weather/ (pasim_blocks.weather): the echo through the weather channel at each
fidelity level."""
