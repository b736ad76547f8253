"""The PASIM-graph block library, cut the way the signal flows.

Installed under the import name ``pasim_blocks``; every block registers through the
``pasim_graph.blocks`` entry-point group, exactly as a third-party plugin would. The
subsystem packages, in the order of the chain: :mod:`~pasim_blocks.waveforms` (the pulse),
:mod:`~pasim_blocks.transmitters` (amplifiers, jitter), :mod:`~pasim_blocks.antennas`
(patterns), :mod:`~pasim_blocks.truth` (the scene the radar looks at),
:mod:`~pasim_blocks.scans` (which beams), :mod:`~pasim_blocks.weather` (the echo),
:mod:`~pasim_blocks.receivers` (filters, noise), :mod:`~pasim_blocks.processing` (moments,
scores). Shared by several of them: :mod:`~pasim_blocks.signals` (port types and constants),
:mod:`~pasim_blocks.angles`; the FM-301 vocabulary (moment names, units, CF attributes) is the
engine's :mod:`pasim_graph.fm301`. :mod:`~pasim_blocks.commands` holds
the sub-commands that measure a graph (``pasim waveform``, ``pasim pattern``).
"""

from pathlib import Path

#: The default scene carried with the package: a real NEXRAD Level-II volume (KLBB,
#: 2016-06-01 15:00 UTC, public-domain NOAA data) with a convective line north-west of the radar.
DEFAULT_SCENE = Path(__file__).parent / "data" / "KLBB20160601_150025_V06"
