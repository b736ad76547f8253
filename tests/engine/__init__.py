"""Tests of the engine's graph (pasim_graph): files, ports, validation, the command line, the
registry and plugins."""
