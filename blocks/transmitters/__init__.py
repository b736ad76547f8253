"""Transmitters: what happens to the pulse before it is radiated. High-power amplifier models
(``amplifier.ideal``, ``amplifier.saleh``, ``amplifier.rapp`` in :mod:`.amplifiers`, with the
output's rise and fall edges), pulse-to-pulse amplitude and phase jitter
(``transmitter.jitter`` in :mod:`.jitter`), the power divider that splits one transmitter
between the ports (``transmitter.power_divider`` in :mod:`.divider`), and the radiated
spectrum against the NTIA RSEC emission mask (:mod:`.emission`, used by ``pasim spectrum``)."""
