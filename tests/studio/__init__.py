"""Tests of the studio (pasim_graph.studio): its model, HTTP API and page."""
