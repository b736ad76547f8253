"""Processing: the six moments from the I/Q (pulse-pair, SHV and AHV, :mod:`.pulse_pair`) and
their errors against the truth, judged by the NEXRAD requirements (:mod:`.scorer`). Blocks:
``processor.pulse_pair``, ``scorer.nexrad``."""
