"""Waveforms: the transmitted pulse (rectangular, LFM, NLFM, from a file), the NLFM design
(stationary-phase envelopes), and pulse-compression figures (range sidelobes, efficiency, SNR
loss). Blocks: ``waveform.rectangular``, ``waveform.lfm``, ``waveform.nlfm``, ``waveform.file``
(:mod:`.pulses`)."""
