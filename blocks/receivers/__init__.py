"""Receivers: the receive filter (matched or mismatched, :mod:`.filters`: the range response a
gate sees and the noise bandwidth it passes) and the thermal noise at its output
(:mod:`.receiver`). Blocks: ``filter.matched``, ``filter.mismatched``, ``receiver.basic``."""
