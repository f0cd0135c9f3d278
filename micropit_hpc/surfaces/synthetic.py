"""Synthetic rough surfaces from a seed, identical on any number of MPI ranks (docs/model.md §3).

Every field is filtered white noise: h = F⁻¹[ √S(k) · F[n] ], with n the unit white noise of
:func:`white_noise` and S the power spectrum of the requested surface, then shifted to zero mean
and scaled to exactly the requested R_q (so the normalisation of S does not matter).

Determinism (docs/hpc.md §2): row i of the noise comes from its own stream
``SeedSequence(seed, spawn_key=(*spawn_key, i))``, so any slab of rows is generated alone and
the full field does not depend on how rows are split between ranks. The transforms here use
``numpy.fft`` (pocketfft), not the pyFFTW plans of :mod:`micropit_hpc.spectral`: a plan made with
FFTW_MEASURE is chosen by timing, so two processes can pick different algorithms and differ at
round-off (observed on this machine), which would break bitwise equality across ranks and runs.
A surface is generated once per run, so the slower transform costs little.
"""

from __future__ import annotations

import math

import numpy as np

from micropit_hpc.spectral import Grid
from micropit_hpc.surfaces.topography import Topography, TopographyError

__all__ = ["ACF_KINDS", "gaussian_surface", "self_affine_surface", "white_noise"]

ACF_KINDS = ("exponential", "gaussian")
_LN10 = math.log(10.0)  # ACF(β) = e^{−ln 10} = 0.1 exactly (Patir 1978 rounds it to 2.3)


def _row_range(grid: Grid, rows) -> range:
    if rows is None:
        return range(grid.nx)
    if isinstance(rows, slice):
        return range(grid.nx)[rows]
    if isinstance(rows, range):
        if len(rows) and not (0 <= min(rows) and max(rows) < grid.nx):
            raise TopographyError(f"rows = {rows!r}: outside the grid rows 0..{grid.nx - 1}")
        return rows
    raise TopographyError(f"rows = {rows!r}: must be None, a slice or a range")


def white_noise(grid: Grid, seed: int, rows=None, spawn_key: tuple = ()) -> np.ndarray:
    """Unit Gaussian white noise on ``grid``, shape (len(rows), ny); all rows when rows is None.

    Row i is ``default_rng(SeedSequence(seed, spawn_key=(*spawn_key, i))).standard_normal(ny)``
    (docs/hpc.md §2), so a rank owning rows [i0, i1) generates exactly its slab with
    ``rows=slice(i0, i1)``; ``spawn_key`` separates independent fields (e.g. the two bodies).
    """
    if not isinstance(seed, int | np.integer) or isinstance(seed, bool) or seed < 0:
        raise TopographyError(f"seed = {seed!r}: must be a non-negative integer")
    r = _row_range(grid, rows)
    out = np.empty((len(r), grid.ny))
    for k, i in enumerate(r):
        ss = np.random.SeedSequence(int(seed), spawn_key=(*spawn_key, i))
        out[k] = np.random.default_rng(ss).standard_normal(grid.ny)
    return out


def _filtered(grid: Grid, amplitude: np.ndarray, rq: float, seed: int,
              spawn_key: tuple) -> np.ndarray:
    """Zero-mean field of R_q = rq: noise filtered by ``amplitude`` = √S on the half spectrum."""
    amplitude = np.array(amplitude)
    amplitude[0, 0] = 0.0  # the mean
    spec = np.fft.rfft2(white_noise(grid, seed, spawn_key=spawn_key)) * amplitude
    h = np.fft.irfft2(spec, s=grid.shape)
    h -= h.mean()
    rms = np.sqrt(np.mean(h * h))
    if not rms > 0:
        raise TopographyError(f"no wavenumber of the {grid.nx}x{grid.ny} grid over {grid.lx:.6g} "
                              f"m x {grid.ly:.6g} m carries power in this spectrum: the "
                              "correlation length or cut-offs do not fit the window")
    return h * (rq / rms)


def _check(name: str, value, allow_inf: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TopographyError(f"{name} = {value!r}: not a number") from None
    if not (v > 0 and (math.isfinite(v) or (allow_inf and v == math.inf))):
        raise TopographyError(f"{name} = {value!r}: must be positive"
                              + (" (inf allowed)" if allow_inf else " and finite"))
    return v


#: Images of the ACF are summed while they can exceed this (relative to R(0) = 1).
_ACF_IMAGE_FLOOR = 1e-17


def _acf(tx: np.ndarray, ty: np.ndarray, acf: str) -> np.ndarray:
    """R at the lags (τx/βx, τy/βy) given as 1-D arrays (outer grid)."""
    tx, ty = np.asarray(tx)[:, None], np.asarray(ty)[None, :]
    r2 = tx * tx + ty * ty
    return np.exp(-_LN10 * (np.sqrt(r2) if acf == "exponential" else r2))


def _periodic_acf(grid: Grid, bx: float, by: float, acf: str) -> np.ndarray:
    """Σ_m R(τ + m L) at the grid's lags, over the images that can exceed
    :data:`_ACF_IMAGE_FLOOR`; β_y = inf: R is constant along y, no images in y. The Gaussian
    R is separable, so its images are two 1-D sums; the exponential's are summed in 2-D."""
    reach = math.log(1 / _ACF_IMAGE_FLOOR) / _LN10      # a·d = ln(1/floor) at the last image
    if acf == "gaussian":
        reach = math.sqrt(reach)

    def lags(n, length, beta):
        base = np.fft.fftfreq(n) * length / beta
        if beta == math.inf:
            return base, [0]
        m = int(math.ceil(reach * beta / length + 0.5))
        return base, range(-m, m + 1)

    (tx, mx), (ty, my) = lags(grid.nx, grid.lx, bx), lags(grid.ny, grid.ly, by)
    sx, sy = grid.lx / bx, (grid.ly / by if by != math.inf else 0.0)
    if acf == "gaussian":
        rx = sum(np.exp(-_LN10 * (tx + i * sx) ** 2) for i in mx)
        ry = sum(np.exp(-_LN10 * (ty + j * sy) ** 2) for j in my)
        return rx[:, None] * ry[None, :]
    r = np.zeros(grid.shape)
    for i in mx:
        for j in my:
            near = math.hypot(max(abs(i) - 0.5, 0.0) * sx, max(abs(j) - 0.5, 0.0) * sy)
            if near <= reach:
                r += _acf(tx + i * sx, ty + j * sy, acf)
    return r


def gaussian_surface(grid: Grid, rq: float, corr_x: float, corr_y: float, seed: int,
                     acf: str = "exponential", spawn_key: tuple = (),
                     periodic_acf: bool = True) -> Topography:
    """Gaussian random field of R_q = ``rq`` [m] with correlation lengths β_x, β_y [m].

    β is the lag at which the autocorrelation R falls to 0.1 (Patir, Wear 47 (1978) 263), with
    a = ln 10 (Patir's 2.3, rounded):
      "exponential": R(τx, τy) = exp(−a √((τx/βx)² + (τy/βy)²)),
      "gaussian":    R(τx, τy) = exp(−a ((τx/βx)² + (τy/βy)²)).
    Ground gear flanks and discs have their lay across the rolling direction: β_y ≫ β_x
    (ridges along y); ``corr_y = inf`` gives perfectly transverse ridges, constant along y.
    The filter is √S with S the DFT of R sampled at the grid's lags (Hu & Tonder, Int. J.
    Mach. Tools Manuf. 32 (1992) 83), R taken **periodic**: the sum of its images
    Σ_m R(τ + m L) over the window's periods (``periodic_acf``, the default), i.e. the continuous
    spectrum sampled at the window's wavenumbers and aliased onto the grid (round-off negatives
    set to 0), without the loss of the spectral tail that sampling the continuous spectrum
    alone (∝ (a² + (k_x β_x)² + (k_y β_y)²)^(−3/2) for the exponential) would cause. A field on a
    periodic window has a periodic autocorrelation, so where R has not died out at half the
    window (R(L/2) = 0.08 for the Gaussian ACF at β = 0.9 × L/2, the paper scenes' β_y) the
    field's ACF is R plus its images. ``periodic_acf = False`` is the generator before
    2026-11-25: R at the minimum-image lags, which has a kink at the half-window lag ±L/2
    whenever R(L/2) ≠ 0; that kink puts a spectral tail ∝ k⁻² (and the clipped negative lobes
    of its ringing) at every wavenumber up to the Nyquist, so the "Gaussian" field was not
    band-limited and a finer grid resolved more roughness (docs/performance.md, "The MPR rig's
    film share"). β should be well below the window size; β ≲ Δx approaches white noise.
    """
    rq, bx, by = _check("rq", rq), _check("corr_x", corr_x), _check("corr_y", corr_y, True)
    if acf not in ACF_KINDS:
        raise TopographyError(f"acf = {acf!r}: unknown (allowed: {', '.join(ACF_KINDS)})")
    r = (_periodic_acf(grid, bx, by, acf) if periodic_acf
         else _acf(np.fft.fftfreq(grid.nx) * grid.lx / bx,
                   np.fft.fftfreq(grid.ny) * grid.ly / by, acf))
    s = np.maximum(np.fft.rfft2(r).real, 0.0)
    if by == math.inf:
        s *= grid.ky == 0  # exactly constant along y
    h = _filtered(grid, np.sqrt(s), rq, seed, spawn_key)
    prov = (f"gaussian_surface(rq={rq!r} m, corr_x={bx!r} m, corr_y={by!r} m, acf={acf!r}, "
            f"seed={seed}, spawn_key={tuple(spawn_key)}"
            f"{'' if periodic_acf else ', periodic_acf=False'}) on {grid.nx}x{grid.ny} over "
            f"{grid.lx!r} m x {grid.ly!r} m")
    return Topography(h, grid.dx, grid.dy, prov)


def self_affine_surface(grid: Grid, rq: float, hurst: float, long_cutoff: float,
                        short_cutoff: float, seed: int, spawn_key: tuple = ()) -> Topography:
    """Isotropic self-affine (fractal) field of R_q = ``rq`` [m] and Hurst exponent 0 < H < 1.

    PSD (Persson et al., J. Phys.: Condens. Matter 17 (2005) R1; Jacobs, Junge & Pastewka,
    Surf. Topogr. Metrol. Prop. 5 (2017) 013001):
      C(q) ∝ q_L^{−2(1+H)}  for q < q_L = 2π/long_cutoff   (flat roll-off),
      C(q) ∝ q^{−2(1+H)}    for q_L ≤ q ≤ q_s = 2π/short_cutoff,
      C(q) = 0              for q > q_s,
    with q = |k|. A long cut-off beyond the window puts the roll-off below the lowest mode
    2π/L; a short cut-off below 2Δx leaves the grid's Nyquist wavenumber π/Δx as the limit.
    """
    rq = _check("rq", rq)
    lc, sc = _check("long_cutoff", long_cutoff), _check("short_cutoff", short_cutoff)
    if not 0 < hurst < 1:
        raise TopographyError(f"hurst = {hurst!r}: must be in (0, 1)")
    if not sc < lc:
        raise TopographyError(f"short_cutoff = {sc!r} m: must be below long_cutoff = {lc!r} m")
    q = grid.kappa
    amplitude = np.maximum(q, 2 * math.pi / lc) ** -(1 + hurst) * (q <= 2 * math.pi / sc)
    h = _filtered(grid, amplitude, rq, seed, spawn_key)
    prov = (f"self_affine_surface(rq={rq!r} m, hurst={hurst!r}, long_cutoff={lc!r} m, "
            f"short_cutoff={sc!r} m, seed={seed}, spawn_key={tuple(spawn_key)}) on "
            f"{grid.nx}x{grid.ny} over {grid.lx!r} m x {grid.ly!r} m")
    return Topography(h, grid.dx, grid.dy, prov)
