"""Tests of blocks/waveforms/ (pasim_blocks.waveforms): the transmitted pulse, pulse compression,
``pasim waveform``."""
