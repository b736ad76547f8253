"""Weather: the channel from the truth cells to the echo at every gate (``channel.weather`` in
:mod:`.channel`), at four fidelity levels, each its own module: :mod:`.expected` (expected
correlations, no draw), :mod:`.combined` (each gate's series at once), :mod:`.per_cell`
(``covariance`` and ``monte_carlo``, whose per-cell series models are in :mod:`.cells`).
Shared by them: the beam's weights of the cells (:mod:`.beams`), Doppler spectra and their
colouring (:mod:`.spectra`), fast time (the range response, :mod:`.fasttime`) and the
polarimetric scattering and coupling (:mod:`.polarimetry`).
"""

from ..deprecated import forward

# ``pasim_blocks.weather`` was the module now at :mod:`.channel` (and its helpers): its names
# still resolve here, with a deprecation warning, for one release.
__getattr__ = forward(__name__)
