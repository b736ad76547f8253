"""The PASIM-graph block library: one module per radar subsystem.

Installed under the import name ``pasim_blocks``; every block registers through the
``pasim_graph.blocks`` entry-point group, exactly as a third-party plugin would.
"""

from pathlib import Path

#: The default scene carried with the package: a real NEXRAD Level-II volume (KLBB,
#: 2016-06-01 15:00 UTC, public-domain NOAA data) with a convective line north-west of the radar.
DEFAULT_SCENE = Path(__file__).parent / "data" / "KLBB20160601_150025_V06"
