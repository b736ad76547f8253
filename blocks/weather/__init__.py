"""Weather: the channel from the truth cells to the echo at every gate (``channel.weather`` in
:mod:`.channel`), at four fidelity levels, each its own module: :mod:`.expected` (expected
correlations, no draw), :mod:`.combined` (each gate's series at once), :mod:`.per_cell`
(``covariance`` and ``monte_carlo``, whose per-cell series models are in :mod:`.cells`).
Shared by them: the beam's weights of the cells (:mod:`.beams`), Doppler spectra and their
colouring (:mod:`.spectra`), fast time (the range response, :mod:`.fasttime`) and the
polarimetric scattering and coupling (:mod:`.polarimetry`).
"""
