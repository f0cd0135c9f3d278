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

from micropit_hpc.compiled import resolve
from micropit_hpc.errors import MicropitError
from micropit_hpc.parallel.slab import Reductions
from micropit_hpc.spectral import Grid, rfft_plan


class ContactError(MicropitError):
    """A contact problem that has no solution or whose solver did not converge;
    ``iterations``: the CG iterations the failed solve spent (0 where none ran)."""

    def __init__(self, message: str, iterations: int = 0):
        super().__init__(message)
        self.iterations = iterations


@dataclass(frozen=True)
class DryContact:
    """Solution of a dry contact problem (SI).

    ``gap`` is the deformed gap g = g0 + u − δ (0 on elastic contact to the solve's accuracy,
    :attr:`gap_accuracy`; < 0 where plastic); ``approach`` is δ;
    ``error`` the final relative residual (see :func:`solve_dry_contact`); ``iterations`` all CG
    steps of the solve, the coarse-to-fine start's included.
    From a distributed solve, ``pressure`` and ``gap`` (and so :attr:`contact` and
    :attr:`area_fraction`) are this rank's rows only.
    """

    pressure: np.ndarray
    gap: np.ndarray
    approach: float
    iterations: int
    error: float
    #: Of ``iterations``, those spent on the coarse grids of the coarse-to-fine start (each
    #: costs 1/4, 1/16, … of an iteration on the window's grid).
    coarse_iterations: int = 0
    #: [m] The gap at or below which a point touches to the solve's accuracy:
    #: :data:`CLEARANCE_MARGIN` × the residual the solve stopped at (its threshold on ε times
    #: rms(g0 − mean g0)); 0 for the exact solutions (no load, a flat gap). On an elastic
    #: contact point g is 0 but for the residual, whose sign is round-off: with
    #: ``lubrication.h_min_um`` = 0 (the default) "clearance ≤ h_min" alone put about half of
    #: the elastic contact points out of solid contact (the paper gear's position 3 at 256²,
    #: one dry step: 251 of 463), so the step's solid contact is "clearance ≤ max(h_min,
    #: gap_accuracy)" (:meth:`~micropit_hpc.cycle.PositionCycle.solve_step`).
    gap_accuracy: float = 0.0

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
        self._transfer = self._interleaved(self.compliance)

    @property
    def rows(self) -> slice:
        """The x rows of the window that :meth:`displacement` works on (all without a slab)."""
        return slice(0, self.grid.nx) if self.slab is None else self.slab.rows

    @property
    def distributed(self) -> bool:
        """True when the rows are split over several ranks."""
        return self.slab is not None and self.slab.comm.size > 1

    def displacement(self, p: np.ndarray) -> np.ndarray:
        """Combined normal displacement u(p) of the two surfaces (zero mean) [m], a new array.
        With a slab: ``p`` and u are this rank's rows (collective)."""
        return self.response(p).copy()

    @property
    def input_buffer(self) -> np.ndarray | None:
        """Where :meth:`response` reads its field when called without one: the serial
        transform's own input buffer (whole window), or None when the rows are distributed."""
        return None if self.distributed else self._fft.real_input

    def response(self, p: np.ndarray | None = None) -> np.ndarray:
        """u(p) as :meth:`displacement`, without the copy out: a view of the transform's
        output buffer (or the slab's), overwritten by the next transform; ``p`` None takes the
        field already written into :attr:`input_buffer` (serial only). Collective with a slab.
        """
        return self._apply(self._transfer, p)

    def stiffness_response(self, f: np.ndarray | None = None) -> np.ndarray:
        """The inverse response applied to ``f``: irfft2((E'κ/4) · rfft2(f)), the pressure whose
        displacement is f (less its mean), as a view of the transform's output buffer like
        :meth:`response` (``f`` None: the field in :attr:`input_buffer`). The preconditioner of
        the contact's CG (:func:`_polonsky_keer`). Collective with a slab."""
        return self._apply(self._stiffness_transfer, f)

    @cached_property
    def _stiffness_transfer(self) -> np.ndarray:
        """:attr:`stiffness` in the layout of :meth:`stiffness_response`'s transform."""
        return self._interleaved(self.stiffness)

    def _interleaved(self, values: np.ndarray) -> np.ndarray:
        """A transfer function on the half spectrum in the layout :meth:`_apply` multiplies
        by: the transforms' 1/(nx·ny) folded in, each value twice (RealFFT2.convolve);
        distributed, only the slab's k_y columns (Slab.filtered)."""
        return (self.slab.interleaved(values) if self.distributed
                else self._fft.interleaved(values))

    def _apply(self, transfer: np.ndarray, f: np.ndarray | None) -> np.ndarray:
        """irfft2(transfer · rfft2(f)) as a view of the transform's output buffer (``f`` None:
        the field in :attr:`input_buffer`). Collective with a slab."""
        if not self.distributed:
            return self._fft.convolve(transfer, f)
        return self.slab.filtered(f, transfer)

    @cached_property
    def self_compliance(self) -> float:
        """K₀ [m/Pa]: the combined displacement of one cell under unit pressure on that cell
        alone, on this grid: the diagonal of the discrete compliance operator. For a square
        cell of side s it is within 3 % of the continuum value 8 s asinh(1)/(π E') (uniform
        pressure on a square, Love 1929; Johnson, *Contact Mechanics* (1985) §3.2). Computed
        on the whole window on this rank (not collective), with or without a slab."""
        unit = np.zeros(self.grid.shape)
        unit[0, 0] = 1.0
        transfer = self._fft.interleaved(self.compliance) if self.distributed else self._transfer
        return float(self._fft.convolve(transfer, unit)[0, 0])

    @cached_property
    def stiffness(self) -> np.ndarray:
        """E'κ/4 per mode (0 at the mean): p̂ = stiffness · û, the inverse response."""
        stiff = np.zeros_like(self.compliance)
        np.divide(1.0, self.compliance, out=stiff, where=self.compliance > 0)
        return stiff


#: Updates of the yielded set made with inexact (√tol) elastic solves before the search goes on
#: at the full tolerance (:func:`solve_dry_contact`; at most this many per rung, below); 0:
#: every solve at the full tolerance.
LOOSE_UPDATES = 8
#: The inexact search's tolerances ("rungs") in a cold solve started from a coarser grid's
#: pressure (the coarse-to-fine start, below), loosest first: tol^(1/2 + j/(2R)) for
#: j = 0 … R−1 with R = COLD_RUNGS, then tol itself (:func:`loose_rungs`). Every other solve
#: has one rung, √tol (at 64², with no coarser grid, a second one only added iterations), and
#: so does a contact with no point at the cap (no set to seek). From such a start's √tol the
#: search at tol spent most of its iterations converging pressures of a set that was about to
#: change; the rung between finds those changes at a lower cost (measured on the paper gear
#: at 256²–2048²: docs/performance.md §11, "Rungs between √tol and tol"). 1: √tol alone.
COLD_RUNGS = 2
#: Whether the early updates (below) go on in the rungs after the first.
EARLY_EVERY_RUNG = True

#: Whether the CG direction restarts from steepest descent whenever points enter the contact
#: (Polonsky & Keer 1999, δ = 0 after a change of the contact set). False: the directions stay
#: conjugate through entries as through exits (:func:`_polonsky_keer`).
RESET_ON_ENTRY = False
#: A solve whose residual has not reached a new low for this many iterations restarts its
#: direction from steepest descent (once per stall): kept directions can cycle when a few
#: points are left in the elastic contact, e.g. between open micropits (a 64² gear step with
#: 62 % of the window pitted: 3 points, residual stuck at 9e-4 for 4,864 iterations; with
#: the restart the whole solve took 339; tests/test_dry_contact.py).
STALL_ITERATIONS = 200

#: Whether the CG is preconditioned by the inverse response (Vollebregt's FFT preconditioner,
#: J. Comput. Phys. 257 (2014) 333–351: the direction from S(g on the contact), S = E'κ/4 per
#: mode, one more transform per iteration; :func:`_polonsky_keer`) in the phases of a solve
#: whose tolerance is at most :data:`PRECONDITION_TOL`: from their start in every rung of the
#: yielded set's search after the first (their early updates included) and at the full
#: tolerance; in the first rung's full solves, and in a contact with no point at the cap, once
#: the contact set has held for :data:`PRECONDITION_STEADY` iterations; never in the first
#: rung's early updates, whose set it made flip back and forth (the paper gear at 2048²: all
#: 32 early updates, ±5,000 points each, where 7 found the set without it). While points still
#: enter and leave the contact it slows the CG (a random rough surface preconditioned from
#: the start: 1.33× and 1.46× the iterations per doubling, against 1.21× without it); on a set
#: that holds it cuts the iterations that grow with the grid (the gear's cold step: 1.16×
#: instead of 1.50× from 1024² to 2048²; docs/performance.md §11, "The preconditioner on a
#: set that holds"). False: the plain CG throughout.
PRECONDITION = True
#: Iterations the contact set must hold (no point entering or leaving) before an adaptive solve
#: turns the preconditioner on.
PRECONDITION_STEADY = 1
#: No phase looser than this relative residual is preconditioned: from a loose start three
#: preconditioned iterations left pressures whose yielded set flipped back and forth at every
#: early update (the 1024² level inside the paper gear's 2048² solve, its rung at 7e-4: 12
#: updates, ±800 points each), and the mixed model's 1e-3 scan trials took more iterations
#: (4 327 → 5 196 over a 64² position's cycle).
PRECONDITION_TOL = 1e-5

#: Early updates of the yielded set in a cold solve (:func:`solve_dry_contact` without
#: ``p_init``, and each level of its coarse-to-fine start): while the inexact search's set
#: still changes, it is updated after this many CG iterations instead of after an elastic
#: solve to √tol; once an update leaves it unchanged the search goes on as before (the solve
#: finished to √tol, then to tol). The set of a cold start is far from the answer, and every
#: update restarts the CG, so converging the elastic pressure of a set about to change was
#: wasted (the paper gear's steps at 64²–1024²: 0.5–0.7× the fine grid's iterations, the same
#: pressure error; docs/performance.md §11, "Early updates of the yielded set"). 0: none.
#: Warm starts (whose set is nearly the answer already) keep the full inexact solves.
EARLY_UPDATE_ITERATIONS = 3
#: At most this many early updates per solve (a set that keeps changing then goes on with
#: the full inexact solves, whose release threshold stops points flipping for ever).
EARLY_UPDATES_MAX = 32

#: The implementation of the iteration's elementwise stages that :func:`solve_dry_contact` uses
#: when none is given: "auto" (compiled where Numba can be imported, else NumPy), "numba" or
#: "numpy" (:mod:`micropit_hpc.compiled`). A module-level switch for whole runs.
DEFAULT_KERNEL = "auto"


class NumpyStages:
    """The elementwise stages of one Polonsky–Keer iteration with NumPy (the reference;
    ``_dry_numba`` fuses each into one pass). Every stage works in place on this rank's
    arrays and returns the local sums the solver reduces over the group; the contact set
    p > 0 is taken once per iteration (:meth:`gap`) and kept until :meth:`update`."""

    def __init__(self, shape):
        self._mask = np.empty(shape, dtype=bool)
        self._tmp = np.empty(shape)
        self._enter = np.empty(shape, dtype=bool)

    def gap(self, g0, u, c, p, g):
        """g = g0 + c u; (Σ g, count) over the contact points."""
        np.multiply(u, c, out=g)
        g += g0
        np.greater(p, 0.0, out=self._mask)
        return g.sum(where=self._mask), np.count_nonzero(self._mask)

    def centre(self, g, p, mean):
        """g −= mean; Σ g² over the contact points."""
        g -= mean
        np.multiply(g, g, out=self._tmp)
        return self._tmp.sum(where=self._mask)

    def direction(self, g, p, t, beta, out, shift=0.0):
        """t = g − shift + β t on the contact, 0 elsewhere; also into ``out``."""
        if beta:
            t *= beta
            t += g
        else:
            t[...] = g
        if shift:
            t -= shift
        np.multiply(t, self._mask, out=t)
        if out is not t:
            out[...] = t

    def masked(self, g, p, out):
        """out = g on the contact, 0 elsewhere (the preconditioner's input)."""
        np.multiply(g, self._mask, out=out)

    def preconditioned_sums(self, z, g, p):
        """(Σ z, Σ g z) over the contact."""
        np.multiply(g, z, out=self._tmp)
        return z.sum(where=self._mask), self._tmp.sum(where=self._mask)

    def project(self, r, t, g, p):
        """(Σ r over the contact, Σ r t, Σ t, Σ g t) (t vanishes off the contact)."""
        return (r.sum(where=self._mask), float(np.vdot(r, t)), t.sum(), float(np.vdot(g, t)))

    def update(self, p, t, g, c, tau, allowed, out):
        """p = max(c p − τ t, 0); points at 0 with g < 0 (and allowed) enter at −τ g; also
        into ``out``; (points entered, Σ p)."""
        p *= c
        np.multiply(t, tau, out=self._tmp)
        p -= self._tmp
        np.maximum(p, 0.0, out=p)
        enter = self._enter
        np.equal(p, 0.0, out=enter)
        enter &= g < 0.0
        if allowed is not None:
            enter &= allowed
        np.multiply(g, tau, out=self._tmp)
        np.subtract(p, self._tmp, out=p, where=enter)
        if out is not p:
            out[...] = p
        return np.count_nonzero(enter), p.sum()


class CompiledStages:
    """:class:`NumpyStages` on the compiled kernels of ``mod`` (``_dry_numba``): one pass each."""

    def __init__(self, mod):
        self.k = mod
        self._none = np.zeros(1, dtype=bool)

    def gap(self, g0, u, c, p, g):
        return self.k.gap(g0.reshape(-1), u.reshape(-1), c, p.reshape(-1), g.reshape(-1))

    def centre(self, g, p, mean):
        return self.k.centre(g.reshape(-1), p.reshape(-1), mean)

    def direction(self, g, p, t, beta, out, shift=0.0):
        self.k.direction(g.reshape(-1), p.reshape(-1), t.reshape(-1), beta, out.reshape(-1),
                         shift)

    def masked(self, g, p, out):
        self.k.masked(g.reshape(-1), p.reshape(-1), out.reshape(-1))

    def preconditioned_sums(self, z, g, p):
        return self.k.preconditioned_sums(z.reshape(-1), g.reshape(-1), p.reshape(-1))

    def project(self, r, t, g, p):
        return self.k.project(r.reshape(-1), t.reshape(-1), g.reshape(-1), p.reshape(-1))

    def update(self, p, t, g, c, tau, allowed, out):
        restricted = allowed is not None
        return self.k.update(p.reshape(-1), t.reshape(-1), g.reshape(-1), c, tau,
                             allowed.reshape(-1) if restricted else self._none, restricted,
                             out.reshape(-1))


def iteration_stages(shape, kernel: str | None = None):
    """The stages of :func:`_polonsky_keer` for fields of ``shape``: compiled or NumPy by
    ``kernel`` (None: :data:`DEFAULT_KERNEL`)."""
    mod = resolve(DEFAULT_KERNEL if kernel is None else kernel, "lubrication._dry_numba",
                  "solve_dry_contact")
    return NumpyStages(shape) if mod is None else CompiledStages(mod)


def _polonsky_keer(g0: np.ndarray, hs: ElasticHalfSpaces, P: float, scale: float,
                   tol: float, max_iter: int, p: np.ndarray,
                   excluded: np.ndarray | None, N: int,
                   group: Reductions, stages, work: tuple[np.ndarray, np.ndarray] | None = None,
                   precondition: str | None = None,
                   ) -> tuple[np.ndarray, np.ndarray, int, float, float]:
    """Elastic load-controlled contact, Polonsky & Keer (1999) eqs. (13)–(22); points in
    ``excluded`` carry no pressure and may not enter. Unlike their δ = 0 after points enter the
    contact, the direction stays conjugate through entries (:data:`RESET_ON_ENTRY`): each
    step is still the exact minimiser along its direction, and the restarts, one at nearly
    every iteration on a rough contact, had turned the CG into steepest descent, whose
    iterations grow ∝ n (docs/performance.md, "Contact iterations that do not grow with the
    grid": 131/204 → 105/144 iterations at 256²/512², the same pressure error). A kept
    direction that no longer descends (Σ g t ≤ 0) is replaced by steepest descent in that
    iteration (one more convolution): stepping backwards, points would enter at −τ g < 0 (seen
    on a nearly flat, heavily worn surface, tests/test_hard_cases.py).
    Returns (p, g − ḡ, iterations, ε, ḡ): ḡ is the mean gap over the contact points, the rigid
    approach δ of g = g0 + u(p) − δ (to round-off).
    ``g0``, ``p``, ``excluded``: this rank's rows of the ``N`` points of the window (C-ordered;
    ``p`` is updated in place); every sum and scalar product is reduced over ``group``.
    ``work``: two arrays of ``g0``'s shape for the gap and the direction (None: new ones); the
    gap returned is the first.

    One iteration is two convolutions u(p) and u(t) and five elementwise passes, the
    ``stages`` (:func:`iteration_stages`). The fields they write for a convolution go straight
    into the transform's input buffer, the responses are read from its output buffer, the
    transforms' normalisation sits in the transfer function, and the load's rescaling of p is
    kept as a factor c (the true pressure is c·p: u(c p) = c u(p), and p > 0 marks the same
    contact) that the next update applies (docs/performance.md §10).

    ``precondition``: None, the plain residual g as above; "on": preconditioned CG with
    Vollebregt's FFT preconditioner (J. Comput. Phys. 257 (2014) 333–351, §4), z = S(g on the
    contact) with S the inverse response E'κ/4 (:meth:`ElasticHalfSpaces.stiffness_response`),
    the direction t = (z − z̄) + β t on the contact (z̄ its mean there, so that t keeps the
    load) and β = Σ g z / Σ g_old z_old: a third transform per iteration; "adapt": plain until
    the contact set has held for :data:`PRECONDITION_STEADY` iterations, then "on" (the
    directions restart there). The step, the projection and the stopping rule are the same."""
    allowed = None if excluded is None else ~excluded
    if allowed is not None:
        p[excluded] = 0.0
    (p_sum,) = group.sums(p.sum())
    if p_sum <= 0.0:        # the start had its load on excluded points only: uniform instead
        p[...] = 1.0 if allowed is None else allowed
        (p_sum,) = group.sums(p.sum())
    buf = hs.input_buffer
    if buf is not None:
        buf[...] = p
    c = P * N / p_sum
    if work is None:
        g, t = np.empty_like(g0), np.zeros_like(g0)
    else:
        g, t = work
        t.fill(0.0)
    R_old, conjugate, error, mean = 1.0, False, math.inf, 0.0
    it = best_it = 0
    best = math.inf
    pre = precondition == "on"
    steady, last_contact, n_enter = 0, -1.0, 1
    z_in = None if buf is not None or not precondition else np.empty_like(g0)
    while it < max_iter:
        it += 1
        u = hs.response(p if buf is None else None)
        g_sum, n_contact = group.sums(*stages.gap(g0, u, c, p, g))
        mean = g_sum / n_contact
        (G,) = group.sums(stages.centre(g, p, mean))
        error = math.sqrt(G / n_contact) / scale
        if error <= tol:
            break
        if error < best:
            best, best_it = error, it
        elif it - best_it >= STALL_ITERATIONS:     # stalled: restart the directions
            conjugate, best_it = False, it
        if precondition == "adapt" and not pre:
            # on once the contact set has held (no point in or out) for PRECONDITION_STEADY
            # iterations; the directions restart there
            steady = steady + 1 if n_contact == last_contact and not n_enter else 0
            last_contact = n_contact
            if steady >= PRECONDITION_STEADY:
                pre, conjugate = True, False
        while True:
            source, shift, R = g, 0.0, G
            if pre:
                # z = S(g on the contact), S the inverse response; the direction is z less its
                # mean over the contact, and R = Σ g z replaces G in β (Σ g = 0 there)
                stages.masked(g, p, z_in if buf is None else buf)
                z = hs.stiffness_response(z_in)
                z_sum, gz = group.sums(*stages.preconditioned_sums(z, g, p))
                if gz > 0.0:
                    source, shift, R = z, z_sum / n_contact, gz
                else:       # no descent in it at round-off level: the plain residual
                    conjugate = False
            stages.direction(source, p, t, R / R_old if conjugate else 0.0,
                             t if buf is None else buf, shift)
            r = hs.response(t if buf is None else None)
            r_sum, rt, t_sum, gt = group.sums(*stages.project(r, t, g, p))
            if gt > 0.0 or not conjugate:
                break
            # a kept direction that no longer descends (Σ g t ≤ 0: the step would go
            # backwards, and points entering at −τ g would enter with negative pressure):
            # this iteration restarts from steepest descent, whose Σ g t = G > 0 (Σ g z > 0
            # preconditioned)
            conjugate = False
        R_old = R
        curvature = rt - r_sum / n_contact * t_sum     # Σ (r − r̄_contact) t
        if curvature <= 0.0:   # no descent left at round-off level
            break
        tau = gt / curvature
        n_enter, p_sum = group.sums(*stages.update(p, t, g, c, tau, allowed,
                                                   p if buf is None else buf))
        conjugate = not (n_enter and RESET_ON_ENTRY)
        c = P * N / p_sum
    p *= c
    return p, g, it, error, mean


#: The grid at which ``tol`` is the relative residual ε itself (points along the longer side;
#: :func:`residual_threshold`); 0: ε ≤ tol on every grid (the rule before, whose pressure
#: error grew with the grid).
TOLERANCE_POINTS = 256
#: How the threshold on ε shrinks with the grid beyond :data:`TOLERANCE_POINTS`: (n₀/n)^a,
#: a measured (docs/performance.md, "Contact iterations that do not grow with the grid").
TOLERANCE_EXPONENT = 0.4


def loose_rungs(tol: float, rungs: int | None = None) -> list[float]:
    """The inexact tolerances of the yielded set's search before ``tol``, loosest first:
    tol^(1/2 + j/(2R)), j = 0 … R−1 (R = ``rungs``, None: :data:`COLD_RUNGS`), those above
    ``tol`` only (none for tol ≥ 1)."""
    R = COLD_RUNGS if rungs is None else int(rungs)
    out = [tol ** (0.5 + j / (2 * R)) for j in range(max(R, 0))]
    return [t for t in out if t > tol]


def residual_threshold(tol: float, grid: Grid) -> float:
    """The relative residual ε (:func:`solve_dry_contact`) at which a solve of tolerance
    ``tol`` on ``grid`` stops: tol · min(1, (n₀/n)^a), n = max(nx, ny) the points along the
    longer side, n₀ = :data:`TOLERANCE_POINTS`, a = :data:`TOLERANCE_EXPONENT`; so that one
    ``tol`` leaves the same pressure error ‖p − p*‖/‖p*‖ (p* a tight reference) on every grid
    of a window from n₀ up.

    Why: ε measures the gap residual r; the pressure error it leaves is the inverse response
    applied to r, p̂ − p̂* = (E'|k|/4) r̂ (docs/model.md §4.1 step 1), whose factor grows with
    the wavenumber up to π/dx: on a window of fixed size refined (dx ∝ 1/n) the pressure
    error of a given ε grows with n, ∝ n at most (a residual all at the grid scale). Measured
    with this solver on a random rough surface and on the paper gear's rough contact at
    256²–1024²: error/ε grows as n^0.40 on both (2.3 → 3.0 → 4.1 and 7.5 → 9.7 → 13, the
    medians over tol = 1e-5 … 1e-11), hence a = 0.4. Below n₀ the plain ε ≤ tol is kept (no
    solve is looser than before)."""
    n0 = TOLERANCE_POINTS
    if n0 <= 0:
        return tol
    return tol * min(1.0, n0 / max(grid.nx, grid.ny)) ** TOLERANCE_EXPONENT


#: :attr:`DryContact.gap_accuracy` in units of the residual a solve stopped at: the gap of
#: a contact point is within a few residuals of 0 (at most 2.1 and 3.0 of them on the paper
#: gear's 256² and 512² dry steps, 2.9–6.4 on four 256² random rough gaps, elastic and
#: capped), and a point out of contact whose gap is within 100 of them (a few pm) touches to
#: the solve's accuracy (one point in those ten solves).
CLEARANCE_MARGIN = 100.0

#: The coarse-to-fine start of a cold solve (:func:`solve_dry_contact` without ``p_init``):
#: the window is coarsened by 2 while both sides stay even and the coarse grid keeps at least
#: this many points per side; 0 turns the start off (every cold solve from uniform pressure).
COARSEST = 64
#: The tolerance of the coarse solves of that start: None, the fine solve's; else the larger of
#: the two.
COARSE_TOL: float | None = 1e-4


def restrict(f: np.ndarray) -> np.ndarray:
    """The field on the grid coarsened by 2 (even nx, ny): full weighting, the (1/4, 1/2, 1/4)
    stencil along each axis, periodic, at the fine points (2I, 2J) that the coarse points
    (I, J) coincide with (both grids put point i at (i − n/2)·dx, so coarse point I lies on
    fine point 2I). Keeps the mean exactly in exact arithmetic (Trottenberg, Oosterlee &
    Schüller, *Multigrid* (2001), ch. 2); here it restricts the undeformed gap."""
    a = 0.5 * f + 0.25 * (np.roll(f, 1, axis=0) + np.roll(f, -1, axis=0))
    a = a[::2]
    b = 0.5 * a + 0.25 * (np.roll(a, 1, axis=1) + np.roll(a, -1, axis=1))
    return np.ascontiguousarray(b[:, ::2])


def prolong(fc: np.ndarray) -> np.ndarray:
    """The coarse field on the grid refined by 2: bilinear interpolation, periodic (fine point
    2I is coarse point I, fine point 2I + 1 the mean of coarse points I and I + 1; the
    transpose of :func:`restrict` up to a factor 4, Trottenberg et al. (2001), ch. 2), one axis
    after the other. Each new value is the mean of two (x, then y), so between equal values
    (points held at the cap p_lim) it is that value exactly, and it stays within the coarse
    field's bounds: a pressure in [0, p_lim] stays there."""
    nxc, nyc = fc.shape
    a = np.empty((2 * nxc, nyc))
    a[::2] = fc
    a[1::2] = 0.5 * (fc + np.roll(fc, -1, axis=0))
    f = np.empty((2 * nxc, 2 * nyc))
    f[:, ::2] = a
    f[:, 1::2] = 0.5 * (a + np.roll(a, -1, axis=1))
    return f


def coarse_levels(grid: Grid, coarsest: int | None = None) -> int:
    """How many times the coarse-to-fine start of :func:`solve_dry_contact` halves ``grid``:
    while both sides are even and the halved grid keeps ≥ ``coarsest`` (None:
    :data:`COARSEST`) points per side; 0 when ``coarsest`` is 0."""
    m = COARSEST if coarsest is None else int(coarsest)
    if m <= 0:
        return 0
    nx, ny, levels = grid.nx, grid.ny, 0
    while nx % 2 == 0 and ny % 2 == 0 and min(nx, ny) // 2 >= m:
        nx, ny, levels = nx // 2, ny // 2, levels + 1
    return levels


def _coarse_start(g0_whole: np.ndarray, grid: Grid, E_prime: float, P: float, p_lim: float,
                  tol: float, max_iter: int, levels: int, kernel,
                  free_whole: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """The coarse-to-fine start (nested iteration, "full multigrid" start; Brandt, Math. Comp.
    31 (1977) 333–390; Venner & Lubrecht, *Multilevel Methods in Lubrication* (2000)):
    the whole window's gap restricted ``levels`` times (:func:`restrict`), the contact solved
    on the coarsest grid from uniform pressure, its pressure (and with it the contact and the
    yielded set: p > 0, p = p_lim) prolongated (:func:`prolong`) to start the solve of the next
    finer grid, up to the grid below ``grid``; returns that pressure prolongated onto ``grid``
    and the CG iterations spent. Serial on the whole window (a distributed solve runs it on
    every rank alike: the coarse grids are ≤ 1/4 of the points). Each coarse problem is the
    same contact on the same window (E', load, cap), sampled coarser; the columns held
    free (``free_whole``) are free on a coarse grid where at least half of a coarse cell's
    area is (the coarse grids only start the fine solve). A level may spend at most half of
    the iterations left, so that one that fails (its iterations counted all the same) leaves
    the fine solve at least half of what the levels before it left."""
    gaps, frees = [g0_whole], [None if free_whole is None else free_whole.astype(float)]
    for _ in range(levels):
        gaps.append(restrict(gaps[-1]))
        frees.append(None if frees[-1] is None else restrict(frees[-1]))
    p, used = None, 0
    for level in range(levels, 0, -1):
        g = gaps[level]
        cg = Grid(g.shape[0], g.shape[1], grid.lx, grid.ly)
        hs = ElasticHalfSpaces(cg, E_prime)
        free = None if frees[level] is None else frees[level] >= 0.5
        try:
            sol = solve_dry_contact(g, hs, P, p_lim, tol=tol,
                                    max_iter=(max_iter - used) // 2,
                                    p_init=p, kernel=kernel, coarsest=0, free=free,
                                    early_updates=True)
        except ContactError as e:   # e.g. a tolerance below the coarse grid's round-off:
            return None, used + e.iterations    # the fine solve starts from uniform pressure
        used += sol.iterations
        p = prolong(sol.pressure)
    return p, used


def solve_dry_contact(gap0: np.ndarray, half_spaces: ElasticHalfSpaces, mean_pressure: float,
                      p_lim: float = math.inf, *, tol: float, max_iter: int,
                      p_init: np.ndarray | None = None,
                      kernel: str | None = None, coarsest: int | None = None,
                      free: np.ndarray | None = None,
                      early_updates: bool | None = None) -> DryContact:
    """Load-controlled elastic–perfectly-plastic contact of the undeformed gap ``gap0``.

    Elastic part: Polonsky & Keer (1999), converged when the relative residual

        ε = rms(g − ḡ over the elastic contact points) / rms(g0 − mean g0)
          ≤ tol · min(1, 256/n)^0.4   (n = max(nx, ny); :func:`residual_threshold`)

    so that one ``tol`` leaves the same pressure error ‖p − p*‖/‖p*‖ on every grid of a window
    from 256² up (the table in docs/performance.md, "Contact iterations that do not grow with
    the grid").

    Cold start (``p_init`` None): a coarse-to-fine sequence (:func:`_coarse_start`) on the
    window coarsened by 2, 4, … down to ``coarsest`` points per side (None:
    :data:`COARSEST`; 0: none, the start from uniform pressure): the gap restricted, the
    pressure with its contact and yielded sets prolongated level by level; the solve on this
    grid starts from there. Its answer meets the same conditions at the same tolerance as the
    single-level solve's (tests/test_dry_contact.py); ``iterations`` counts the coarse
    levels' too (:attr:`DryContact.coarse_iterations`).

    Cap 0 ≤ p ≤ p_lim (docs/model.md §4.1 step 3; p_lim = 0.6 H by default there): the plastic
    set is found by the fixed-point iteration of Jacq et al. (J. Tribol. 124 (2002) 653–667):
    points at p_lim are held at the cap, the elastic problem is solved on the rest, points whose
    elastic pressure exceeds the cap join the set and points of the set whose gap opens (by
    more than the residual ε·rms(g0 − mean g0)) leave it, until the set no longer changes.
    The set is first sought with inexact solves, at √tol (and, in a solve started from a
    coarser grid's pressure with points at the cap, then at tol^(3/4): :data:`COLD_RUNGS`),
    and confirmed at tol. The phases at a tolerance of at most :data:`PRECONDITION_TOL` run
    the preconditioned CG (:data:`PRECONDITION`). ``kernel``: the implementation of the
    iteration's elementwise stages (:func:`iteration_stages`; None: :data:`DEFAULT_KERNEL`);
    the compiled and the NumPy stages agree to round-off. ``p_init`` warm-starts the iteration
    (e.g. the previous time step's pressure); ``max_iter`` bounds the total number of CG
    steps. ``tol`` and ``max_iter`` are the scene's ``lubrication.tolerance`` and
    ``lubrication.max_iterations`` (:class:`~micropit_hpc.scene.LubricationSpec`), which the
    callers pass.

    ``early_updates``: whether the yielded set's search starts with early updates, every
    :data:`EARLY_UPDATE_ITERATIONS` CG iterations while the set changes (None: for a cold
    solve, ``p_init`` None; the coarse-to-fine start's levels have them too). Only the path
    to the set changes: the answer meets the same conditions at the same tolerance.

    ``free``: points held at p = 0 whatever their gap (bool, this rank's rows; None: none),
    the open micropits of ``life.pit_contact = "open"`` (docs/life.md): the load goes to
    the other points, and the gap returned there is the undeformed one plus the elastic
    displacement (it may be negative: nothing touches there). The load must fit under the
    cap on the other points.

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
    g0 = np.ascontiguousarray(gap0, dtype=float)
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
    held = None
    if free is not None:
        held = np.ascontiguousarray(free, dtype=bool)
        if held.shape != local_shape:
            raise ValueError(f"free shape {held.shape} != gap shape {local_shape}")
        (n_held,) = group.sums(np.count_nonzero(held))
        if not n_held:
            held = None
        elif P * N >= p_lim * (N - n_held):
            raise ContactError(
                f"dry contact: mean pressure {P / 1e9:.4g} GPa over the {N - int(n_held)} of "
                f"{N} points not held free would reach the cap p_lim = {p_lim / 1e9:.4g} GPa")
    if held is None and group.max(g0.max()) - g_min == 0.0:
        # flat: uniform pressure is the exact solution
        return DryContact(np.full_like(g0, P), np.zeros_like(g0), float(g0_mean), 0, 0.0)

    stages = iteration_stages(g0.shape, kernel)
    used = 0
    if early_updates is None:
        early_updates = p_init is None
    levels = coarse_levels(grid, coarsest) if p_init is None else 0
    if levels:
        whole = g0 if hs.slab is None else hs.slab.allgather_rows(g0)
        free_whole = (None if held is None else
                      held if hs.slab is None else hs.slab.allgather_rows(held))
        p_whole, used = _coarse_start(whole, grid, hs.E_prime, P, p_lim,
                                      tol if COARSE_TOL is None else max(tol, COARSE_TOL),
                                      max_iter, levels, kernel, free_whole)
        p_init = None if p_whole is None else p_whole[rows]
    coarse_used = used
    p = np.full_like(g0, P) if p_init is None else np.maximum(p_init, 0.0).astype(float, copy=False)
    if not group.any(p):
        p[...] = P
    plastic = p >= p_lim
    if held is not None:      # a warm start from before the pits: they yield no more
        p[held] = 0.0
        plastic &= ~held
    error, settled = math.inf, False
    left = None         # the points released once at the full tolerance (see below)
    early_left = EARLY_UPDATES_MAX if early_updates and EARLY_UPDATE_ITERATIONS > 0 else 0
    updates = 0
    # With a finite cap the yielded set is first sought with inexact elastic solves (tolerance
    # √tol): a set that will change anyway needs no converged pressure. The search goes on at
    # tol once the set holds at √tol, once a solve starts already within √tol (the inexact
    # pressures no longer move, and a few points could flip in and out of the set for ever)
    # or after LOOSE_UPDATES updates. The answer has to meet the same conditions at tol.
    # A cold solve first updates the set every EARLY_UPDATE_ITERATIONS iterations, until an
    # update leaves it unchanged (or after EARLY_UPDATES_MAX of them).
    # A cold solve started from a coarser grid's pressure (its set nearly the answer, its
    # residual soon within √tol) climbs COLD_RUNGS such rungs, √tol, tol^(3/4), … to tol, each
    # left as √tol is (LOOSE_UPDATES counted per rung); every other solve one.
    tol_given, tol = tol, residual_threshold(tol, grid)
    prolongated = early_updates and p_init is not None
    rungs = (loose_rungs(tol, None if prolongated else 1)
             if math.isfinite(p_lim) and LOOSE_UPDATES > 0 else [])
    phase_tol = rungs.pop(0) if rungs else tol
    first_rung, rung_updates = True, 0
    # g0 plus the yielded points' displacement, made anew only when the set has changed since
    # (``version`` counts the changes; a rung or an early update that leaves the set as it
    # was keeps it): the same array, one convolution less
    g_fixed, version, fixed_version = g0, 0, -1
    work = (np.empty_like(g0), np.empty_like(g0))
    while used < max_iter:
        updates += 1
        rung_updates += 1
        (n_pl,) = group.sums(np.count_nonzero(plastic))
        n_pl = int(n_pl)
        P_el = P - p_lim * n_pl / N if n_pl else P
        if P_el <= 0.0:   # the cap alone would carry more than the load: start the set anew
            plastic[...] = False
            n_pl, P_el = 0, P
            version += 1
        if not n_pl:
            g_fixed = g0
        else:
            if fixed_version != version:
                g_fixed = g0 + hs.displacement(np.where(plastic, p_lim, 0.0))
                fixed_version = version
            p = np.where(plastic, 0.0, p)
            if not group.any(p):
                p = np.where(plastic, 0.0, P_el)
        excluded = plastic if n_pl else None
        if held is not None:
            excluded = held if excluded is None else excluded | held
        capped = early_left > 0 and phase_tol > tol and (first_rung or EARLY_EVERY_RUNG)
        budget = min(max_iter - used, EARLY_UPDATE_ITERATIONS) if capped else max_iter - used
        precondition = (None if not PRECONDITION or phase_tol > PRECONDITION_TOL
                        or (capped and first_rung) else
                        "adapt" if first_rung else "on")
        p, g, it, error, approach = _polonsky_keer(g_fixed, hs, P_el, scale, phase_tol,
                                                   budget, p, excluded, N, group, stages, work,
                                                   precondition)
        used += it
        early = capped and error > phase_tol and it == budget
        if error > phase_tol and not early:
            break
        p_total = np.where(plastic, p_lim, p)
        grow = p > p_lim
        # a yielded point leaves the set when its gap opens by more than the solve's residual
        # (ε · rms(g0), the gap's accuracy): a gap open by less is g = 0 to that accuracy, and
        # releasing it let points flip in and out of the set for ever (one iteration per
        # update), seen on the paper gear's 512² and 1024² windows
        release = plastic & (g > phase_tol * scale)
        if phase_tol <= tol:
            # At the full tolerance a point leaves the set at most once: one that came back
            # stays. A point on the edge of the yielded set can be outside both states by the
            # solve's accuracy, its gap open by a little more than the residual at the cap and
            # its elastic pressure above the cap by an ulp without it; it then left and came
            # back at every update, each a one-iteration solve, until max_iterations (a coarse
            # level of the paper gear's position 2 at 512², step 20: 4925 updates, 12 s, then
            # the fine solve from uniform pressure; tests/test_dry_contact.py)
            if left is None:
                left = np.zeros_like(plastic)
            release &= ~left
            left |= release
        n_grow, n_release = group.sums(np.count_nonzero(grow), np.count_nonzero(release))
        if early:       # an early update: not counted in LOOSE_UPDATES
            updates -= 1
            rung_updates -= 1
            early_left -= 1
            if n_grow or n_release:
                plastic = (plastic & ~release) | grow
                version += 1
            else:       # the set held: from here on the inexact solves run to √tol
                early_left = 0
            p = p_total
            np.minimum(p, p_lim, out=p)
            continue
        if phase_tol > tol and (it <= 1 or rung_updates >= LOOSE_UPDATES
                                or not (n_grow or n_release)):
            # the next rung; after the last, or with no yielded point to seek (an elastic
            # contact: the rung would only split its solve), the exact search (or its
            # confirmation)
            phase_tol = rungs.pop(0) if rungs and (n_pl or n_grow) else tol
            first_rung, rung_updates = False, 0
            if not (n_grow or n_release):
                p = p_total
                continue
        elif not n_grow and not n_release:
            p, settled = p_total, True
            break
        plastic = (plastic & ~release) | grow       # n_grow or n_release: a new set
        version += 1
        p = p_total
        np.minimum(p, p_lim, out=p)
    if not settled:
        why = (f"the coarse-to-fine start took all {coarse_used} iterations"
               if math.isinf(error) else
               f"relative residual {error:.3g} > {tol:.3g} (tolerance {tol_given:.3g} on "
               f"this grid)" if error > tol else
               f"the set of yielded points still changed at update {updates}")
        raise ContactError(
            f"dry contact did not converge: {why} after {used} iterations (raise "
            "lubrication.max_iterations or the tolerance; "
            "check that the roughness is resolved by the grid)", iterations=used)
    # g = g0 + u(p) − δ with δ the last CG step's mean contact gap: the yielded points' share
    # of u is in g_fixed, the others' in the step's gap (g0 + u(p) − g = δ to round-off)
    return DryContact(p, g, float(approach), used, error, coarse_used,
                      CLEARANCE_MARGIN * tol * scale)
