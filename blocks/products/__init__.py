"""Radar products of a finished run: what a person looks at after ``pasim run``.

:mod:`.moment_figures` draws a store's truth, estimate and error of each moment as PPIs with the
weather-radar colour maps (``pasim plot``, the studio's run pictures, the study report's maps).
The store itself (the CfRadial-2 layout and its scores) is written and read by the engine's
executor (:mod:`pasim_graph.store`), which owns storage; the pictures are radar knowledge
(moment names, units, colour maps, limits) and live here, so the engine knows none of it.
:mod:`.exchange_files` writes a run as CF/Radial 1, CF/Radial 2 or ODIM_H5 with the truth
beside the moments (``pasim export``), through xradar's writers.
"""
