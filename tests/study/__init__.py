"""Tests of blocks/study/ (pasim_blocks.study): trade studies, their statistics and report,
``pasim compare``."""
