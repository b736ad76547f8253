"""Tests of blocks/transmitters/ (pasim_blocks.transmitters): amplifiers, jitter, transmit power,
``pasim spectrum``."""
