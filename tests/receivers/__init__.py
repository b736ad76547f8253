"""Tests of blocks/receivers/ (pasim_blocks.receivers): receive filters, noise and the receiver's
impairments."""
