"""Tests of blocks/truth/ (pasim_blocks.truth): the scene from Level-II and other radar files,
grids, ``pasim fetch``."""
