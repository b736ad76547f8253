"""Commands that read a graph to measure it, registered as ``pasim`` sub-commands through the
``pasim_graph.commands`` entry points: ``pasim waveform`` (:mod:`.waveform`: range sidelobes,
efficiency and resolution of a graph's waveform chain) and ``pasim pattern`` (:mod:`.pattern`:
beamwidths, sidelobes, gain, cross-polarisation of its antenna). They import the subsystem
packages; nothing imports them."""
