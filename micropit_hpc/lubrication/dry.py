"""Dry elastic–perfectly-plastic contact of two rough surfaces on a periodic window, by FFT.

The problem (docs/model.md §4.1 step 3, level ``dry``): find the pressure p(x, y) with mean P and
0 ≤ p ≤ p_lim, and the rigid approach δ, such that the deformed gap

    g = g0 + u(p) − δ,   û(k) = 4 p̂(k) / (E' |k|)   (k ≠ 0; both bodies, docs/model.md §4.1 step 1)

satisfies g ≥ 0 where p = 0, g = 0 where 0 < p < p_lim, and g ≤ 0 where p = p_lim (the material
has yielded and the surfaces interpenetrate by the plastically flattened height).

Solved by the conjugate-gradient method of Polonsky & Keer (Wear 231 (1999) 206–219) on the set
of elastic contact points, extended with the upper bound: points at p_lim are held at the cap and
leave it when their gap opens, as points at zero pressure enter the contact when their gap closes.
The load is imposed exactly after every step (scaling of the pressures, with the cap).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from micropit_hpc.errors import MicropitError
from micropit_hpc.parallel.slab import Reductions
from micropit_hpc.spectral import Grid, rfft_plan


class ContactError(MicropitError):
    """A contact problem that has no solution or whose solver did not converge."""


@dataclass(frozen=True)
class DryContact:
    """Solution of a dry contact problem (SI).

    ``gap`` is the deformed gap g = g0 + u − δ (0 on elastic contact, < 0 where plastic);
    ``approach`` is δ; ``error`` the final relative residual (see :func:`solve_dry_contact`).
    From a distributed solve, ``pressure`` and ``gap`` (and so :attr:`contact` and
    :attr:`area_fraction`) are this rank's rows only.
    """

    pressure: np.ndarray
    gap: np.ndarray
    approach: float
    iterations: int
    error: float

    @property
    def contact(self) -> np.ndarray:
        """Points that carry pressure."""
        return self.pressure > 0.0

    @property
    def area_fraction(self) -> float:
        return float(np.count_nonzero(self.pressure > 0.0)) / self.pressure.size


class ElasticHalfSpaces:
    """The combined surface compliance of two elastic half-spaces on a periodic grid:
    û = (4/(E' κ)) p̂ (docs/model.md §4.1 step 1; Johnson, Contact Mechanics §3.? for one body:
    2(1−ν²)/(E κ)). The mean mode is left out: a uniform pressure only moves the bodies
    together, which the rigid approach accounts for.

    ``slab``: a :class:`~micropit_hpc.parallel.slab.Slab` of a work item's group over which
    the contact is distributed (docs/hpc.md §2): :meth:`displacement` then takes and returns
    this rank's x rows (``slab.rows``) and transforms by the slab's distributed FFT, and
    :func:`solve_dry_contact` works on rows with the group's reductions. None (default): the
    whole window on this rank. A one-rank slab computes the same numbers as None.
    """

    def __init__(self, grid: Grid, E_prime: float, slab=None):
        self.grid = grid
        self.E_prime = float(E_prime)
        kappa = grid.kappa.copy()
        kappa[0, 0] = 1.0
        self.compliance = 4.0 / (self.E_prime * kappa)
        self.compliance[0, 0] = 0.0
        self._fft = rfft_plan(grid.shape)
        self.slab = slab
        self._transfer = (None if slab is None
                          else np.ascontiguousarray(self.compliance[:, slab.cols]))

    @property
    def rows(self) -> slice:
        """The x rows of the window that :meth:`displacement` works on (all without a slab)."""
        return slice(0, self.grid.nx) if self.slab is None else self.slab.rows

    @property
    def distributed(self) -> bool:
        """True when the rows are split over several ranks."""
        return self.slab is not None and self.slab.comm.size > 1

    def displacement(self, p: np.ndarray) -> np.ndarray:
        """Combined normal displacement u(p) of the two surfaces (zero mean) [m]. With a slab:
        ``p`` and u are this rank's rows (collective)."""
        if self.slab is None:
            return self._fft.filtered(p, self.compliance)
        return self.slab.filtered(p, self._transfer)

    @cached_property
    def self_compliance(self) -> float:
        """K₀ [m/Pa]: the combined displacement of one cell under unit pressure on that cell
        alone, on this grid: the diagonal of the discrete compliance operator. For a square
        cell of side s it is within 3 % of the continuum value 8 s asinh(1)/(π E') (uniform
        pressure on a square, Love 1929; Johnson, *Contact Mechanics* (1985) §3.2). Computed
        on the whole window on this rank (not collective), with or without a slab."""
        unit = np.zeros(self.grid.shape)
        unit[0, 0] = 1.0
        return float(self._fft.filtered(unit, self.compliance)[0, 0])

    @cached_property
    def stiffness(self) -> np.ndarray:
        """E'κ/4 per mode (0 at the mean): p̂ = stiffness · û, the inverse response."""
        stiff = np.zeros_like(self.compliance)
        np.divide(1.0, self.compliance, out=stiff, where=self.compliance > 0)
        return stiff


def _polonsky_keer(g0: np.ndarray, hs: ElasticHalfSpaces, P: float, scale: float,
                   tol: float, max_iter: int, p: np.ndarray,
                   excluded: np.ndarray | None, N: int,
                   group: Reductions) -> tuple[np.ndarray, np.ndarray, int, float]:
    """Elastic load-controlled contact, Polonsky & Keer (1999) eqs. (13)–(22); points in
    ``excluded`` carry no pressure and may not enter. Returns (p, g − ḡ, iterations, ε).
    ``g0``, ``p``, ``excluded``: this rank's rows of the ``N`` points of the window; every sum
    and scalar product is reduced over ``group``."""
    allowed = None if excluded is None else ~excluded
    if allowed is not None:
        p[excluded] = 0.0
    (p_sum,) = group.sums(p.sum())
    p *= P * N / p_sum
    t = np.zeros_like(g0)
    G_old, conjugate, error = 1.0, False, math.inf
    for it in range(1, max_iter + 1):
        g = g0 + hs.displacement(p)
        contact = p > 0.0
        g_sum, n_contact = group.sums(g[contact].sum(), np.count_nonzero(contact))
        g -= g_sum / n_contact
        r_c = np.where(contact, g, 0.0)
        (G,) = group.sums(float(np.vdot(r_c, r_c)))
        error = math.sqrt(G / n_contact) / scale
        if error <= tol:
            return p, g, it, error
        t = r_c + (G / G_old) * t if conjugate else r_c
        t[~contact] = 0.0
        G_old = G
        r = hs.displacement(t)
        (r_sum,) = group.sums(r[contact].sum())
        r -= r_sum / n_contact
        curvature, rt = group.sums(float(np.vdot(r, t)), float(np.vdot(r_c, t)))
        if curvature <= 0.0:   # no descent left at round-off level
            return p, g, it, error
        tau = rt / curvature
        p = p - tau * t
        np.maximum(p, 0.0, out=p)
        enter = (p == 0.0) & (g < 0.0)          # overlap without pressure: enters the contact
        if allowed is not None:
            enter &= allowed
        p[enter] -= tau * g[enter]              # nothing where no point enters
        n_enter, p_sum = group.sums(np.count_nonzero(enter), p.sum())
        conjugate = not n_enter
        p *= P * N / p_sum
    return p, g, max_iter, error


def solve_dry_contact(gap0: np.ndarray, half_spaces: ElasticHalfSpaces, mean_pressure: float,
                      p_lim: float = math.inf, *, tol: float, max_iter: int,
                      p_init: np.ndarray | None = None) -> DryContact:
    """Load-controlled elastic–perfectly-plastic contact of the undeformed gap ``gap0``.

    Elastic part: Polonsky & Keer (1999), converged when the relative residual

        ε = rms(g − ḡ over the elastic contact points) / rms(g0 − mean g0) ≤ tol.

    Cap 0 ≤ p ≤ p_lim (docs/model.md §4.1 step 3; p_lim = 0.6 H by default there): the plastic
    set is found by the fixed-point iteration of Jacq et al. (J. Tribol. 124 (2002) 653–667):
    points at p_lim are held at the cap, the elastic problem is solved on the rest, points whose
    elastic pressure exceeds the cap join the set and points of the set whose gap opens leave
    it, until the set no longer changes. ``p_init`` warm-starts the iteration (e.g. the previous
    time step's pressure); ``max_iter`` bounds the total number of CG steps. ``tol`` and
    ``max_iter`` are the scene's ``lubrication.tolerance`` and ``lubrication.max_iterations``
    (:class:`~micropit_hpc.scene.LubricationSpec`), which the callers pass.

    Distributed (``half_spaces`` built with a slab of several ranks, docs/hpc.md §2):
    collective over the slab's group; ``gap0``, ``p_init`` and the solution's pressure and gap
    are this rank's x rows (``half_spaces.rows``); the approach, iterations and residual are
    the window's, the same on every rank. Equal to the one-rank solution to round-off (the
    sums are added in another order).

    Raises :class:`ContactError` when the load cannot be carried (P ≥ p_lim) or the iteration
    does not converge (on every rank of a group alike).
    """
    hs = half_spaces
    grid = hs.grid
    group = Reductions(hs.slab)
    rows = hs.rows
    g0 = np.asarray(gap0, dtype=float)
    local_shape = (rows.stop - rows.start, grid.ny)
    if g0.shape != local_shape:
        raise ValueError(f"gap shape {g0.shape} != grid {grid.shape}" +
                         ("" if local_shape == grid.shape else f" rows {rows}"))
    P = float(mean_pressure)
    if not math.isfinite(P) or P < 0.0:
        raise ContactError(f"dry contact: mean pressure {P} Pa must be finite and ≥ 0")
    g_min = group.min(g0.min())
    if P == 0.0:
        g = g0 - g_min
        return DryContact(np.zeros_like(g0), g, float(g_min), 0, 0.0)
    if P >= p_lim:
        raise ContactError(
            f"dry contact: mean pressure {P / 1e9:.4g} GPa ≥ the pressure cap p_lim = "
            f"{p_lim / 1e9:.4g} GPa: the whole window would yield (raise the hardness or "
            "lower the load)")
    N = grid.nx * grid.ny
    (g0_sum,) = group.sums(g0.sum())
    g0_mean = g0_sum / N
    (sq_sum,) = group.sums(((g0 - g0_mean) ** 2).sum())
    scale = float(np.sqrt(sq_sum / N))
    if group.max(g0.max()) - g_min == 0.0:  # flat: uniform pressure is the exact solution
        return DryContact(np.full_like(g0, P), np.zeros_like(g0), float(g0_mean), 0, 0.0)

    p = np.full_like(g0, P) if p_init is None else np.clip(p_init, 0.0, None).astype(float)
    if not group.any(p):
        p[...] = P
    plastic = p >= p_lim
    used, error, settled = 0, math.inf, False
    updates = 0
    while used < max_iter:
        updates += 1
        (n_pl,) = group.sums(np.count_nonzero(plastic))
        n_pl = int(n_pl)
        P_el = P - p_lim * n_pl / N if n_pl else P
        if P_el <= 0.0:   # the cap alone would carry more than the load: start the set anew
            plastic[...] = False
            n_pl, P_el = 0, P
        g_fixed = g0
        if n_pl:
            g_fixed = g0 + hs.displacement(np.where(plastic, p_lim, 0.0))
            p = np.where(plastic, 0.0, p)
            if not group.any(p):
                p = np.where(plastic, 0.0, P_el)
        p, g, it, error = _polonsky_keer(g_fixed, hs, P_el, scale, tol, max_iter - used, p,
                                         plastic if n_pl else None, N, group)
        used += it
        if error > tol:
            break
        p_total = np.where(plastic, p_lim, p)
        grow = p > p_lim
        release = plastic & (g > 0.0)
        n_grow, n_release = group.sums(np.count_nonzero(grow), np.count_nonzero(release))
        if not n_grow and not n_release:
            p, settled = p_total, True
            break
        plastic = (plastic & ~release) | grow
        p = p_total
        np.minimum(p, p_lim, out=p)
    if not settled:
        why = (f"relative residual {error:.3g} > tolerance {tol:.3g}" if error > tol else
               f"the set of yielded points still changed at update {updates}")
        raise ContactError(
            f"dry contact did not converge: {why} after {used} iterations (raise "
            "lubrication.max_iterations or the tolerance; "
            "check that the roughness is resolved by the grid)")
    (delta_sum,) = group.sums((g0 + hs.displacement(p) - g).sum())
    return DryContact(p, g, float(delta_sum / N), used, error)
