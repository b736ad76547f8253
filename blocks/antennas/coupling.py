"""Mutual coupling of a planar array: the lattice's S-parameters and the active element pattern.

Elements of a rectangular lattice couple: when element ``n`` is driven by the incident wave
``a_n``, a wave ``S_mn a_n`` comes back out of port ``m``. Driving the whole array with the
excitation ``a`` of a beam, port ``m`` sees its *active reflection coefficient*

    Gamma_m = sum_n S_mn a_n / a_m

and the array radiates the fraction ``1 - sum_m |Gamma_m a_m|^2 / sum_m |a_m|^2`` of the power
its channels deliver (the rest returns to them). For a steered beam ``a_n = T_n exp(-j k
r_n . rho)`` (taper ``T``, ``rho`` the steering direction's (u, v)), that fraction depends on
the direction only, through the phase increments ``psi = (k dx u, k dy v)``:

    M(psi) = 1 - sum_m |sum_n S_mn T_n exp(-j (n - m) . psi)|^2 / sum_m T_m^2.

``M`` is the array's *mismatch factor*: the active (embedded) element pattern here is the
isolated element's pattern times ``sqrt(M)`` in field, per port (the scan-impedance argument:
the array's realised gain at a scan angle is the isolated element's gain there times the array
factor times ``1 - |Gamma|^2``; e.g. Hansen, *Phased Array Antennas*, 2nd ed., ch. 7; Pozar,
"The active element pattern", IEEE Trans. AP-42(8), 1994). At a beam's peak it is exactly the
power the channels deliver and the array radiates; off the peak it is the taper-weighted mean
of the elements' active patterns, an approximation. It is computed once per array for its
design taper (channel errors do not change it).

The coupling is shift-invariant on the lattice: ``S_mn = s(n - m)``, one *kernel* ``s`` per port
(H-H and V-V; H-V coupling between the ports is neglected), ``s(0)`` the isolated element's own
reflection. Two sources:

* ``file`` (:func:`read_coupling_file`): measured or EM-simulated S-parameters of the lattice
  (format in the function and in docs/arrays.md).
* ``model`` (:func:`sheet_kernel`): Wheeler's infinite aperture sheet (H. A. Wheeler, "Simple
  relations derived from a phased-array antenna made of an infinite current sheet", IEEE
  Trans. AP-13(4), 506-514, 1965). Each cell of an infinite array of patches radiates through
  its aperture as a uniform magnetic current sheet on the ground plane (the patch's radiating
  slots point the current along y for the H port, along x for the V port); the cell's scan
  admittance is ``Y(u, v) / Y(0) = (1 - c^2) / cos(theta)``, ``c`` the direction cosine along
  the current (Wheeler's resistance law, dual form: 1 / cos(theta) in the E-plane, cos(theta)
  in the H-plane), purely reactive in invisible space. Matched at broadside, ``Gamma = (Y(0) -
  Y) / (Y(0) + Y)``; the kernel is its Fourier series over one period of ``psi`` (the Floquet
  relation ``Gamma(psi) = sum_d s(d) exp(-j d . psi)``), kept within ``radius`` elements.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .geometry import DualPolField, FaceGeometry

#: The ports whose coupling a kernel describes (H-H and V-V).
PORTS = ("hh", "vv")
#: Columns of a coupling file.
COLUMNS = ("dx_elements", "dy_elements", "port", "s_db", "s_deg")

# Samples per period of psi of the model's Floquet series (the kernel is its inverse FFT).
_MODEL_GRID = 512
# Samples per period of the interpolation table of the mismatch factor.
_TABLE_GRID = 256
# The mismatch tables of the last coupled design (:func:`embed`): an array and its ideal copy
# (the same taper and lattice) share them; one design at a time (80 x 80: a few MB).
_TABLES: dict[tuple, Any] = {}


@dataclass(frozen=True)
class LatticeCoupling:
    """S-parameters of a rectangular lattice by element offset, one kernel per port.

    Attributes
    ----------
    hh, vv : ndarray
        Complex kernels of shape ``(2 R + 1, 2 R + 1)``; ``[R + i, R + j]`` is ``S`` from the
        element ``i`` columns right and ``j`` rows up into the element at the origin (linear,
        not dB).
    source : str
        Where it came from (a file name or the model).
    """

    hh: NDArray[np.complex128]
    vv: NDArray[np.complex128]
    source: str = ""

    @property
    def radius(self) -> int:
        return (self.hh.shape[0] - 1) // 2

    def kernel(self, port: str) -> NDArray[np.complex128]:
        return self.hh if port == "hh" else self.vv


def sheet_reflection(u: NDArray, v: NDArray, port: str) -> NDArray[np.complex128]:
    """Active reflection coefficient of Wheeler's aperture sheet, matched at broadside.

    ``u``, ``v`` are the face direction cosines of the scan (any real values: beyond the unit
    circle the Floquet mode is evanescent and ``|Gamma| = 1``); ``port`` ``"hh"`` (magnetic
    current along y) or ``"vv"`` (along x).
    """
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    along = v if port == "hh" else u
    q = 1.0 - along**2
    # cos(theta) of the Floquet mode; -j sqrt(.) where it is evanescent. Multiplying
    # (Y0 - Y) / (Y0 + Y) through by cos(theta) / Y0 keeps it finite at the horizon.
    w = np.sqrt((1.0 - u**2 - v**2).astype(complex))
    w = np.where(w.imag > 0, np.conj(w), w)
    return np.asarray((w - q) / (w + q))


def sheet_kernel(
    *, spacing_x_m: float, spacing_y_m: float, frequency_hz: float, radius: int
) -> LatticeCoupling:
    """The lattice S-parameters of Wheeler's aperture sheet (see the module docstring)."""
    from ..signals import SPEED_OF_LIGHT

    k = 2.0 * np.pi * frequency_hz / SPEED_OF_LIGHT
    psi = 2.0 * np.pi * np.fft.fftfreq(_MODEL_GRID)  # one period, FFT order
    u = psi[:, None] / (k * spacing_x_m)
    v = psi[None, :] / (k * spacing_y_m)
    kernels = []
    for port in PORTS:
        # s(d) = mean over psi of Gamma(psi) exp(+j d . psi): an inverse FFT.
        s = np.fft.ifft2(sheet_reflection(u, v, port))
        idx = np.arange(-radius, radius + 1)
        kernels.append(s[np.ix_(idx % _MODEL_GRID, idx % _MODEL_GRID)])
    return LatticeCoupling(
        kernels[0], kernels[1], source=f"model (Wheeler aperture sheet, radius {radius})"
    )


def read_coupling_file(path: str) -> LatticeCoupling:
    """Read a lattice's S-parameters from a comma-separated file.

    ``#`` lines are comments; the first other line names the columns ``dx_elements,
    dy_elements,port,s_db,s_deg``; each following line gives, for one element offset (integers:
    columns right, rows up) and one port (``hh`` or ``vv``), ``20 log10 |S|`` in dB and its
    phase in degrees. The offset (0, 0) is the isolated element's own reflection; offsets not
    given are uncoupled (``-inf`` dB is allowed too). By reciprocity ``S(-d) = S(d)``: giving
    one of the two is enough; giving both with different values is an error.
    """
    name = Path(path).name
    entries: dict[tuple[str, int, int], complex] = {}
    header: list[str] | None = None
    with open(path, encoding="utf-8") as fh:
        for lineno, raw in enumerate(fh, start=1):
            line = raw.strip()
            if not line or line.startswith("#"):
                continue
            fields = [f.strip() for f in line.split(",")]
            if header is None:
                if tuple(fields) != COLUMNS:
                    raise ValueError(
                        f"{name}:{lineno}: expected the header {','.join(COLUMNS)}, found {line!r}"
                    )
                header = fields
                continue
            if len(fields) != len(COLUMNS):
                raise ValueError(
                    f"{name}:{lineno}: expected {len(COLUMNS)} values, found {len(fields)}"
                )
            try:
                i, j = int(fields[0]), int(fields[1])
                s_db, s_deg = float(fields[3]), float(fields[4])
            except ValueError:
                raise ValueError(
                    f"{name}:{lineno}: expected integer offsets and numbers in dB and degrees, "
                    f"found {line!r}"
                ) from None
            port = fields[2].lower()
            if port not in PORTS:
                raise ValueError(f"{name}:{lineno}: port must be hh or vv, found {fields[2]!r}")
            if np.isnan(s_db) or s_db > 0.0 or not np.isfinite(s_deg):
                raise ValueError(
                    f"{name}:{lineno}: |S| must be at most 0 dB with a finite phase, "
                    f"found {s_db} dB, {s_deg} deg"
                )
            value = 10.0 ** (s_db / 20.0) * np.exp(1j * np.deg2rad(s_deg))
            for key in ((port, i, j), (port, -i, -j)):
                old = entries.get(key)
                if old is not None and abs(old - value) > 1e-9:
                    raise ValueError(
                        f"{name}:{lineno}: S at offset ({i}, {j}) port {port} contradicts an "
                        f"earlier line (reciprocity: S(-d) = S(d))"
                    )
            entries[(port, i, j)] = entries[(port, -i, -j)] = complex(value)
    if header is None:
        raise ValueError(f"{name}: no header line ({','.join(COLUMNS)})")
    if not entries:
        raise ValueError(f"{name}: no coupling values")
    radius = max(max(abs(i), abs(j)) for _, i, j in entries)
    size = 2 * radius + 1
    kernels = {p: np.zeros((size, size), dtype=complex) for p in PORTS}
    for (port, i, j), value in entries.items():
        kernels[port][radius + i, radius + j] = value
    return LatticeCoupling(kernels["hh"], kernels["vv"], source=name)


def mismatch_samples(kernel: NDArray, taper_x: NDArray, taper_y: NDArray, grid: int) -> NDArray:
    """``M(psi)`` of the module docstring on the ``grid x grid`` samples of one period.

    ``psi_p = 2 pi p / grid`` (FFT order). Exact when ``grid > 4 R`` (``M`` is a trigonometric
    polynomial of degree ``2 R``), to single precision. With a reciprocal kernel
    (``s(-d) = s(d)``) and a symmetric taper, element ``m`` mirrored through the centre sees
    ``Z_m(-psi)``, so half the rows are computed.
    """
    from numpy.lib.stride_tricks import sliding_window_view
    from scipy import fft

    size = kernel.shape[0]
    radius = (size - 1) // 2
    taper = np.outer(taper_x, taper_y)
    padded = np.pad(taper, radius).astype(np.complex64)
    # windows[mx, my] = T[m + d] for d in [-R, R]^2 (zero beyond the array).
    windows = sliding_window_view(padded, (size, size))
    weights = kernel.astype(np.complex64)
    symmetric = (
        np.allclose(kernel, kernel[::-1, ::-1], rtol=0.0, atol=1e-12)
        and np.allclose(taper_x, taper_x[::-1])
        and np.allclose(taper_y, taper_y[::-1])
    )
    n_x = taper_x.size
    paired = n_x // 2 if symmetric else 0

    def power(rows: Any) -> NDArray:
        out = np.zeros((grid, grid))
        for row in rows:  # one row of elements at a time bounds the memory
            # Sum over d of s(d) T(m + d) exp(-j d . psi): an FFT, up to a unit phase factor.
            spectra = fft.fft2(row * weights, s=(grid, grid))
            out += np.sum(spectra.real**2 + spectra.imag**2, axis=0, dtype=np.float64)
        return out

    half = power(windows[:paired])
    # |Z_m'(psi)|^2 = |Z_m(-psi)|^2: the sample at -p (mod grid).
    mirrored = np.roll(half[::-1, ::-1], 1, axis=(0, 1))
    reflected = half + mirrored + power(windows[paired : n_x - paired])
    return np.asarray(1.0 - reflected / np.sum(taper**2))


def mismatch_table(kernel: NDArray, taper_x: NDArray, taper_y: NDArray) -> NDArray:
    """``M(psi)`` on a fine periodic grid (``_TABLE_GRID`` or more samples per period), as the
    cubic B-spline coefficients :func:`interpolate` reads (filtered once here, not per call)."""
    from scipy.ndimage import spline_filter

    radius = (kernel.shape[0] - 1) // 2
    coarse = 16
    while coarse <= 4 * radius:
        coarse *= 2
    samples = mismatch_samples(kernel, taper_x, taper_y, coarse)
    fine = max(_TABLE_GRID, 4 * coarse)
    # Zero-pad the trigonometric polynomial's coefficients (its degree 2R < coarse / 2).
    coeffs = np.fft.fft2(samples)
    padded = np.zeros((fine, fine), dtype=complex)
    half = coarse // 2
    keep = np.r_[0:half, fine - half : fine]
    src = np.r_[0:half, coarse - half : coarse]
    padded[np.ix_(keep, keep)] = coeffs[np.ix_(src, src)]
    table = np.fft.ifft2(padded).real * (fine / coarse) ** 2
    return np.asarray(spline_filter(table, order=3, mode="grid-wrap"))


def interpolate(table: NDArray, psi_x: NDArray, psi_y: NDArray) -> NDArray:
    """``M`` at any ``psi``: periodic cubic spline of a :func:`mismatch_table` (FFT order)."""
    from scipy.ndimage import map_coordinates

    psi_x, psi_y = np.broadcast_arrays(psi_x, psi_y)
    n = table.shape[0]
    coords = np.stack([np.mod(psi_x, 2 * np.pi), np.mod(psi_y, 2 * np.pi)]) * (n / (2 * np.pi))
    out = map_coordinates(table, coords.reshape(2, -1), order=3, mode="grid-wrap", prefilter=False)
    return np.asarray(np.clip(out, 0.0, None).reshape(psi_x.shape))


@dataclass(frozen=True)
class CoupledElement:
    """An element inside its array: a pattern times ``sqrt(M)`` per port.

    The pattern is the base element's (``cell`` False), or with ``cell`` the ideal cell's
    ``sqrt(cos theta)`` carried by the base element's polarisation: a large array's embedded
    element radiates the gain ``4 pi A / lambda^2 cos(theta) (1 - |Gamma|^2)`` of its cell
    area ``A``, whatever the isolated element (Hannan, "The element-gain paradox for a
    phased-array antenna", IEEE Trans. AP-12(4), 1964; Pozar 1994). Tables ``None``: no
    mismatch (``M = 1``).
    """

    base: Any
    table_h: NDArray | None
    table_v: NDArray | None
    psi_per_u: float  # k dx
    psi_per_v: float  # k dy
    cell: bool = False

    def field(self, g: FaceGeometry) -> DualPolField:
        f = self.base.field(g)
        ports = [(f.h_co, f.h_cross, self.table_h), (f.v_co, f.v_cross, self.table_v)]
        out = []
        for co, cross, table in ports:
            gain: Any = 1.0
            if table is not None:
                psi_x, psi_y = self.psi_per_u * g.u, self.psi_per_v * g.v
                gain = np.sqrt(interpolate(table, psi_x, psi_y))
            if self.cell:
                size = np.sqrt(np.abs(co) ** 2 + np.abs(cross) ** 2)
                cosine = np.sqrt(np.clip(g.w, 0.0, None))
                gain = gain * np.where(size > 0, cosine / np.where(size > 0, size, 1.0), 0.0)
            out += [co * gain, cross * gain]
        return DualPolField(*out)


def mismatch_tables(
    coupling: LatticeCoupling,
    taper_x: NDArray,
    taper_y: NDArray,
    *,
    spacing_x_m: float,
    spacing_y_m: float,
    frequency_hz: float,
) -> tuple[NDArray, NDArray, float, float]:
    """H and V mismatch tables of ``coupling`` for an array with this taper, and the
    ``psi`` per unit direction cosine (``k dx``, ``k dy``): the arguments of
    :class:`CoupledElement` after its base element."""
    from ..signals import SPEED_OF_LIGHT

    k = 2.0 * np.pi * frequency_hz / SPEED_OF_LIGHT
    h, v = (
        mismatch_table(_fit(coupling.kernel(p), taper_x.size, taper_y.size), taper_x, taper_y)
        for p in PORTS
    )
    return h, v, k * spacing_x_m, k * spacing_y_m


def _fit(kernel: NDArray, n_x: int, n_y: int) -> NDArray:
    """The kernel cut to the offsets an ``n_x`` by ``n_y`` array has (no effect beyond)."""
    radius = (kernel.shape[0] - 1) // 2
    keep = min(radius, max(n_x, n_y) - 1)
    return kernel[radius - keep : radius + keep + 1, radius - keep : radius + keep + 1]


def check_coupling(get: Callable[[str], Any]) -> list[tuple[str, str]]:
    """Problems with a planar array's coupling parameters (``get``: a parameter's value)."""
    from ..signals import SPEED_OF_LIGHT

    out = []
    coupling, path = get("coupling"), get("coupling_file")
    if coupling == "file" and not path:
        out.append(("parameter 'coupling_file'", "coupling 'file' needs a coupling file"))
    if path and coupling != "file":
        out.append(("parameter 'coupling_file'", f"is set but coupling is {coupling!r}"))
    if coupling == "model":
        half_wave = 0.5 * SPEED_OF_LIGHT / get("frequency_hz")
        for axis in ("x", "y"):
            if get(f"spacing_{axis}_m") > half_wave * (1 + 1e-9):
                out.append(
                    (
                        f"parameter 'spacing_{axis}_m'",
                        f"coupling 'model' (one Floquet mode) needs spacings of at most half"
                        f" a wavelength ({half_wave:.4g} m): use a coupling file",
                    )
                )
    return out


def embed(
    element: Any,
    p: dict[str, Any],
    taper_x: NDArray,
    taper_y: NDArray,
    lattice: LatticeCoupling | None,
) -> Any:
    """A planar array's element inside its array, from the block's parameters ``p``
    (``coupling``, ``embedded_pattern``, ...): the bare element when neither is set."""
    cell = p["embedded_pattern"] == "cell"
    if p["coupling"] == "none":
        return CoupledElement(element, None, None, 0.0, 0.0, cell) if cell else element
    names = (
        *("n_x", "n_y", "spacing_x_m", "spacing_y_m", "frequency_hz", "taper"),
        *("taylor_sll_db", "taylor_nbar", "kaiser_beta", "coupling", "coupling_file"),
    )
    key = (*(p[n] for n in names), p["coupling"] == "model" and p["coupling_radius"])
    if key not in _TABLES:
        geometry = {"spacing_x_m": p["spacing_x_m"], "spacing_y_m": p["spacing_y_m"]}
        lattice = lattice or sheet_kernel(
            **geometry, frequency_hz=p["frequency_hz"], radius=p["coupling_radius"]
        )
        _TABLES.clear()
        _TABLES[key] = mismatch_tables(
            lattice, taper_x, taper_y, frequency_hz=p["frequency_hz"], **geometry
        )
    h, v, psi_per_u, psi_per_v = _TABLES[key]
    return CoupledElement(element, h, v, psi_per_u, psi_per_v, cell)
