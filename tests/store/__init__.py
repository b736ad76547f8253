"""Tests of the store (pasim_graph): what a run writes, its FM-301 vocabulary, safety, resume and
damage."""
