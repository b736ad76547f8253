"""Antennas: one-way H and V patterns around each beam. The pencil beam and the ideal Gaussian
(:mod:`.pencil`), the planar and cylindrical arrays (:mod:`.planar`, :mod:`.cylindrical`, on
the common :mod:`.array` base with its :mod:`.elements` and channel :mod:`.electronics`),
arrays of any geometry (:mod:`.shaped`: line, ring or arc, lattice, a file of element
positions and normals, all computed by :mod:`.conformal` from a :mod:`.layouts` layout), and
the measured antenna (:mod:`.measured`, files in :mod:`.pattern_files`); the pattern
mathematics as pure functions (:mod:`.aperture`, :mod:`.geometry`, :mod:`.tapers`,
:mod:`.array_factor`, :mod:`.measures`). Blocks: ``antenna.pencil``, ``antenna.ideal``,
``antenna.planar``, ``antenna.cylindrical``, ``antenna.linear``, ``antenna.ring``,
``antenna.lattice``, ``antenna.conformal``, ``antenna.measured``."""
