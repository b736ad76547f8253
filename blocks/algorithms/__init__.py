"""Algorithms: the operational radar algorithms of Py-ART run on the simulated sweep, each
stored as new fields and scored against the same algorithm's ideal answer from the truth.
They are sweep-level blocks (``sweep_level = True``: once per sweep, on the whole sweep, after
its chunks are written), since most need neighbouring radials. Blocks:
``algorithm.dealias`` (region-based and unwrap-phase), ``algorithm.zphi`` (attenuation),
``algorithm.kdp`` (Maesaka, Vulpiani, Schneebeli), ``algorithm.despeckle``,
``algorithm.rain_rate`` (from Z and from KDP); :mod:`.sweep_radar` turns a sweep into a Py-ART
radar (docs/algorithms.md)."""
