"""Transmitters: what happens to the pulse before it is radiated. High-power amplifier models
(``amplifier.ideal``, ``amplifier.saleh``, ``amplifier.rapp`` in :mod:`.amplifiers`) and
pulse-to-pulse amplitude and phase jitter (``transmitter.jitter`` in :mod:`.jitter`)."""
