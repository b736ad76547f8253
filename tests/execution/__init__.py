"""Tests of the executors (pasim_graph): dask chunks and clusters, signals, sweep-level stages."""
