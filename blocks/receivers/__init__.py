"""Receivers: the receive filter (matched or mismatched, :mod:`.filters`: the range response a
gate sees and the noise bandwidth it passes), the thermal noise at its output
(:mod:`.receiver`), and the receive chain's impairments: ADC (:mod:`.adc`), gain compression
(:mod:`.gain_compression`), I/Q imbalance (:mod:`.iq_imbalance`) and the oscillator's phase noise
(:mod:`.phase_noise`). Blocks: ``filter.matched``, ``filter.mismatched``, ``receiver.basic``,
``receiver.adc``, ``receiver.compression``, ``receiver.iq_imbalance``,
``receiver.phase_noise``."""
