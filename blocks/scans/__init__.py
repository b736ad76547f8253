"""Scans: which beams the radar forms, where and for how long, and the azimuth geometry shared
with the blocks that compare radials. Block: ``scan.ppi`` (:mod:`.ppi`)."""
