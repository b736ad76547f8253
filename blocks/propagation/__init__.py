"""Propagation: what the path between the radar and the weather does at the simulated radar's
frequency. Rain's specific and differential attenuation and differential phase from the
truth's KDP (:mod:`.rain`), gaseous attenuation (:mod:`.gas`), and their two-way path
integrals applied to the truth as the weather channel sees it (:mod:`.path`).
"""
