"""Truth: the scene the radar looks at, as one sweep of the six moments on a range-azimuth grid.
Real NEXRAD Level-II data (``truth.nexrad`` in :mod:`.nexrad`, read by :mod:`.nexrad_io`) and
synthetic scenes (``scene.uniform``, ``scene.core`` in :mod:`.scenes`).
"""
