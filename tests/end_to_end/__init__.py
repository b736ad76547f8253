"""Whole runs through the command line: ``pasim run``, ``score``, ``plot``, ``tradeoff``."""
