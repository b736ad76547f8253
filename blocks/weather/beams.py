"""What one beam sees: pattern weights of the truth cells (co-polar powers or the complex
co- and cross-polar coupling) and the bundle every drawing path receives.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import xarray as xr

from ..angles import circular_difference
from ..truth.volume import elevation_weights
from .cells import TruthCells
from .chunk_setting import ChunkSetting
from .fasttime import RangeModel
from .polarimetry import (
    SOURCE_COMPONENTS,
    channel_rows,
    pairs,
    receive_channels,
)


def azimuth_profile(
    power: np.ndarray,
    d_el_deg: np.ndarray,
    elevation_deg: float,
    weight: np.ndarray | None = None,
) -> np.ndarray:
    """Two-way pattern integrated over elevation (rad), per polarisation and azimuth offset.

    ``weight`` (one per elevation offset): a volume sweep's share of the truth there; only
    the offsets where it is not zero are summed.
    """
    cos_el = np.cos(np.deg2rad(elevation_deg + d_el_deg))
    step = np.deg2rad(d_el_deg[1] - d_el_deg[0])
    if weight is not None:
        e = np.flatnonzero(weight)
        p = power[:, e].astype(np.float64)
        p *= p
        return np.einsum("e,pea->pa", cos_el[e] * weight[e], p) * step
    p = power.astype(np.float64)
    p *= p
    return np.einsum("e,pea->pa", cos_el, p) * step


class VolumeBeam(NamedTuple):
    """Where one beam reads a volume truth: the flattened cells' rows (sweep-major: sweep s,
    radial j is row s x radials + j), their two-way weights, and each sweep used with its
    weight per elevation offset (for the coupling)."""

    near: np.ndarray
    omega: np.ndarray
    sweeps: list[tuple[int, np.ndarray]]


def volume_beam(
    power: np.ndarray,
    d_az_deg: np.ndarray,
    d_el_deg: np.ndarray,
    elevation_deg: float,
    near_az: np.ndarray,
    delta_deg: np.ndarray,
    width_deg: float,
    weights: np.ndarray,
    radials: int,
    support_db: float,
) -> VolumeBeam:
    """The two-way weights of a volume truth's cells around one beam.

    ``weights`` (sweep x elevation offset) is each sweep's share of the truth at the beam's
    elevation plus each offset (:func:`pasim_blocks.truth.volume.elevation_weights`). Offsets
    where the two-way pattern, integrated over azimuth, is below ``support_db`` from its peak
    are dropped, and a sweep with no weight left costs nothing; each remaining sweep's cells
    are weighted by the pattern over their azimuth extent and over elevation times the sweep's
    share, so the weights of all sweeps add up to the pattern's over the covered elevations.
    """
    cos_el = np.cos(np.deg2rad(elevation_deg + d_el_deg))
    two_way = np.einsum("pea,pea->e", power, power, dtype=np.float64) * cos_el
    inside = two_way >= two_way.max() * 10 ** (support_db / 10)
    rows, omegas, used = [], [], []
    for s in np.flatnonzero((weights[:, inside] > 0).any(axis=1)):
        w = np.where(inside, weights[s], 0.0)
        profile = azimuth_profile(power, d_el_deg, elevation_deg, w)
        omegas.append(cell_solid_angles(profile, d_az_deg, delta_deg, width_deg))
        rows.append(s * radials + near_az)
        used.append((int(s), w))
    if not rows:
        return VolumeBeam(np.zeros(0, np.intp), np.zeros((power.shape[0], 0)), [])
    return VolumeBeam(np.concatenate(rows), np.concatenate(omegas, axis=1), used)


def cell_solid_angles(
    profile: np.ndarray, d_az_deg: np.ndarray, centre_deg: np.ndarray, width_deg: float
) -> np.ndarray:
    """Two-way pattern integral over each truth radial's azimuth extent (sr), per polarisation."""
    step = np.deg2rad(d_az_deg[1] - d_az_deg[0])
    edges = np.concatenate(
        [
            d_az_deg - (d_az_deg[1] - d_az_deg[0]) / 2,
            [d_az_deg[-1] + (d_az_deg[1] - d_az_deg[0]) / 2],
        ]
    )
    out = np.empty((profile.shape[0], centre_deg.size))
    for i in range(profile.shape[0]):
        cum = np.concatenate([[0.0], np.cumsum(profile[i] * step)])
        out[i] = np.interp(centre_deg + width_deg / 2, edges, cum) - np.interp(
            centre_deg - width_deg / 2, edges, cum
        )
    return out


class Coupling(NamedTuple):
    """The two-way polarimetric coupling of one beam's radials (:func:`coupling_weights`).

    ``weights[p, n, j]``: for channel pair p = (k, k') of
    :func:`pasim_blocks.weather.polarimetry.pairs` and source n (S_h, S_v, Y, X), the integral
    over radial j of a_k[c] a_k'[c']* (sr): a cell
    with sources src has E[w_k w_k'*] = sum_n weights[p, n] src_n.
    """

    channels: int
    weights: np.ndarray

    def select(self, n: int) -> np.ndarray:
        """Weights of the pairs of the first ``n`` channels, in ``pairs(n)`` order."""
        index = {p: i for i, p in enumerate(pairs(self.channels))}
        return self.weights[[index[p] for p in pairs(n)]]


def coupling_weights(
    co: np.ndarray,
    cross: np.ndarray,
    d_az_deg: np.ndarray,
    d_el_deg: np.ndarray,
    elevation_deg: float,
    centre_deg: np.ndarray,
    width_deg: float,
    mode: str,
    transmit_phase_deg: float,
    channels: list[tuple[int, int]],
    weight: np.ndarray | None = None,
) -> np.ndarray:
    """Per channel pair and source, the coupling products integrated over each truth radial.

    The two-way couplings a_k[c] of the channels
    (:func:`pasim_blocks.weather.polarimetry.channel_rows`) are multiplied pairwise,
    a_k[c] a_k'[c']*, integrated over elevation with cos(el) and over
    each radial's azimuth extent, as :func:`azimuth_profile` and :func:`cell_solid_angles`
    integrate the squared power pattern. Returns (pair, source, radial) complex (sr).
    """
    cos_el = np.cos(np.deg2rad(elevation_deg + d_el_deg))
    step = np.deg2rad(d_el_deg[1] - d_el_deg[0])
    if weight is not None:
        # A volume sweep's share of the truth: only the elevation offsets it has.
        e = np.flatnonzero(weight)
        co, cross, cos_el = co[..., e, :], cross[..., e, :], cos_el[e] * weight[e]
    rows = channel_rows(co, cross, mode, transmit_phase_deg, channels)
    n_ch, n_el, n_az = rows.shape[0], rows.shape[2], rows.shape[3]
    # Every Hermitian product at once: per azimuth offset, the elevation-weighted Gram matrix
    # of the 2 n_ch coupling rows, summed in float64 (second-order cross-polar terms are
    # 1e-8 of the co-polar ones at -40 dB).
    x = np.empty((n_az, 2 * n_ch, n_el), np.complex128)
    x[...] = rows.reshape(2 * n_ch, n_el, n_az).transpose(2, 0, 1)
    weighted = x * (cos_el * step)
    np.conjugate(x, out=x)
    gram = (weighted @ x.transpose(0, 2, 1)).transpose(1, 2, 0)
    plist = pairs(n_ch)
    profile = np.empty((len(plist), 4, n_az), np.complex128)
    for i, (k, q) in enumerate(plist):
        for n, (c, c2) in enumerate(SOURCE_COMPONENTS):
            profile[i, n] = gram[2 * k + c, 2 * q + c2]
    flat = profile.reshape(-1, n_az)
    both = cell_solid_angles(
        np.concatenate([flat.real, flat.imag]), d_az_deg, centre_deg, width_deg
    )
    half = flat.shape[0]
    return (both[:half] + 1j * both[half:]).reshape(len(plist), 4, centre_deg.size)


def volume_coupling(
    co: np.ndarray,
    cross: np.ndarray,
    d_az_deg: np.ndarray,
    d_el_deg: np.ndarray,
    elevation_deg: float,
    centre_deg: np.ndarray,
    width_deg: float,
    mode: str,
    transmit_phase_deg: float,
    channels: list[tuple[int, int]],
    sweeps: list[tuple[int, np.ndarray]],
    keep: np.ndarray,
) -> np.ndarray:
    """:func:`coupling_weights` of a volume truth's rows (:class:`VolumeBeam`): each sweep's
    radials ``centre_deg`` with its weight over elevation, sweep-major, the rows ``keep``."""
    parts = [np.zeros((len(pairs(len(channels))), 4, 0), np.complex128)]
    for _, weight in sweeps:
        parts.append(
            coupling_weights(
                co,
                cross,
                d_az_deg,
                d_el_deg,
                elevation_deg,
                centre_deg,
                width_deg,
                mode,
                transmit_phase_deg,
                channels,
                weight,
            )
        )
    return np.concatenate(parts, axis=-1)[..., keep]


class BeamDraw(NamedTuple):
    """What every drawing path needs for one beam: the truth cells, the radials near the beam
    and their two-way weights (``omega``: co-polar power patterns; ``coupling``: the complex
    co- and cross-polar fields, None without them), the range model, the beam's H and V random
    streams, the number of channels drawn (1: H only) and the transmission mode."""

    cells: TruthCells
    near: np.ndarray
    omega: np.ndarray
    ranges: RangeModel
    gen_h: np.random.Generator
    gen_v: np.random.Generator
    need_v: bool
    coupling: Coupling | None
    channels: int
    mode: str
    #: Per gate, the weakest per-cell echoes whose summed expected power stays within this
    #: fraction of the gate's total are not drawn (0: every cell; :func:`significant_cells`).
    support_fraction: float = 0.0


def significant_cells(power: np.ndarray, gate: np.ndarray, fraction: float) -> np.ndarray:
    """Which cells to draw: all but, at each gate, the weakest whose powers sum to at most
    ``fraction`` of that gate's total.

    ``power`` is each cell's expected echo power through the two-way pattern and ``gate`` its
    gate (cells of one gate contiguous, as the drawing paths order them). The power left out
    at a gate is at most ``fraction`` of its expected echo, whatever the range response
    spreads it over (one response for every cell of a gate), so the expected power of every
    output gate is low by at most that fraction.
    """
    keep = np.ones(power.size, bool)
    if fraction <= 0 or power.size == 0:
        return keep
    order = np.lexsort((power, gate))  # by gate, weakest first within a gate
    p, g = power[order], gate[order]
    cum = np.cumsum(p)
    first = np.flatnonzero(np.r_[True, g[1:] != g[:-1]])
    counts = np.diff(np.r_[first, p.size])
    before = np.repeat(np.r_[0.0, cum[first[1:] - 1]], counts)
    total = np.repeat(cum[np.r_[first[1:] - 1, p.size - 1]], counts) - before
    keep[order] = (cum - before) > fraction * total
    return keep


def weighted_cells(
    run: ChunkSetting,
    truth: xr.Dataset,
    beams: xr.Dataset,
    pattern: xr.Dataset,
    i: int,
    support: float,
    support_db: float,
    elevation_support_db: float,
) -> tuple[np.ndarray, np.ndarray, Coupling | None]:
    """Beam ``i``'s truth cells and their weights: the rows of the cells whose radials the
    pattern grid reaches (``support``, deg) and weighs above ``support_db`` (a volume's sweeps
    above ``elevation_support_db`` in elevation), their two-way
    solid angles (polarisation x cell), and with complex co- and cross-polar fields the
    two-way coupling of their channels."""
    d_az = pattern["azimuth_offset_deg"].values
    d_el = pattern["elevation_offset_deg"].values
    az_b = float(beams["azimuth"].values[i])
    el_b = float(beams["elevation"].values[i])
    delta = circular_difference(run.az_truth, np.asarray(az_b), 360.0)
    near = np.flatnonzero(np.abs(delta) <= support)
    if run.volume:
        # Each sweep weighted by the two-way pattern over the elevations it stands for.
        seen_by = volume_beam(
            pattern["power"].values[i],
            d_az,
            d_el,
            el_b,
            near,
            delta[near],
            run.width_deg,
            elevation_weights(
                truth["sweep_elevation"].values,
                el_b + d_el,
                str(truth.attrs["elevation_interpolation"]),
                float(truth.attrs["sweep_beamwidth_deg"]),
            ),
            run.az_truth.size,
            elevation_support_db,
        )
        near_az, near, omega = near, seen_by.near, seen_by.omega
        strongest = omega.max(axis=0, initial=0.0)
        floor = strongest.max(initial=0.0) * 10 ** (support_db / 10)
        keep = (strongest >= floor) & (strongest > 0)
    else:
        profile = azimuth_profile(pattern["power"].values[i], d_el, el_b)
        omega = cell_solid_angles(profile, d_az, delta[near], run.width_deg)
        keep = omega.max(axis=0) >= omega.max() * 10 ** (support_db / 10)
    near, omega = near[keep], omega[:, keep]
    if not run.coupled:
        return near, omega, None
    # The expected correlations need both co-polar channels whatever is drawn.
    chans = receive_channels(run.mode, True)[: max(2, run.drawn)]
    co, cross = pattern["co_polar"].values[i], pattern["cross_polar"].values[i]
    if run.volume:
        weights = volume_coupling(
            co,
            cross,
            d_az,
            d_el,
            el_b,
            delta[near_az],
            run.width_deg,
            run.mode,
            run.beta,
            chans,
            seen_by.sweeps,
            keep,
        )
    else:
        weights = coupling_weights(
            co, cross, d_az, d_el, el_b, delta[near], run.width_deg, run.mode, run.beta, chans
        )
    return near, omega, Coupling(len(chans), weights)
