"""Backward-Euler Archard wear over a sub-block: the worn depth that is consistent with the
pressure on the worn surfaces (docs/model.md §4.6, "Integration over a sub-block").

Wearing a solid-contact spot relieves the pressure that wears it, so the wear of a sub-block of
n load cycles is a stiff problem: explicit Archard (n Δh on the starting surfaces) digs the
spots many R_q deep when n is longer than the few thousand cycles their relief takes. The
implicit update solves, for the worn depths w = (w_1, w_2) of both bodies (material frames),

    w = n Δh(w),                                                          (backward Euler)

Δh(w) the Archard wear per load cycle (:func:`~micropit_hpc.wear.archard_wear`) of a load cycle
whose contact is solved on the surfaces worn by w: the relief comes from the contact's own
elastic (and plastic, and film) response, at the scale of each contact spot, not from one grid
cell's compliance. Only the contact is solved inside the iteration (no stresses, no Dang Van).

The fixed point is solved by Anderson acceleration (Walker & Ni, SIAM J. Numer. Anal. 49 (2011)
1715, type II with memory ``memory``) of the map w ↦ n Δh(w). On its own that map diverges on
stiff spots (|n ∂Δh/∂w| ≫ 1); Anderson's least-squares step, a secant method over the last
iterates (a GMRES on the linearised problem), converges on it, but slowly once n|∂Δh/∂w| is in
the hundreds. It is therefore applied to the preconditioned residual M⁻¹(n Δh(w) − w) with the
elastic, spot-scale model of the relief (:class:`SpectralRelief`): wearing a spot in solid
contact by δ lowers its pressure by the half-spaces' stiffness S δ (Ŝ = E'κ/4 per mode,
:attr:`~micropit_hpc.lubrication.dry.ElasticHalfSpaces.stiffness`), so ∂Δh/∂w ≈ −√D S √D with
D the solid Archard coefficient per cycle times the share of the cycle a point spends in solid
contact (:attr:`~micropit_hpc.wear.WearRate.relax` × K₀), and M = I + θ n √D S √D, solved by
conjugate gradients with FFTs. A cell-diagonal M (K₀⁻¹ in place of S) was measured to slow the
iteration: it over-damps the spot-scale and plastic modes; the spectral one does less, and θ
(:data:`RELIEF_SHARE`) < 1 leaves room for the plastic points, which are not relieved, and for
the worn counterface, whose relief the rate map of one body does not see (docs/life.md,
"Implicit wear"). Worn depths never go negative (the iterate is clipped at 0). A ``guess``
(the caller's: the last step's worn depth, scaled to this step) replaces the explicit first
iterate n Δh(0). A uniform removal changes no rate of a contact (it changes nothing the
contact sees), so for such rates (``invariant``) the mean part of the fixed point is solved
exactly: each iterate's worn depth is raised by the mean of its body's residual (no lower than
its shallowest point allows), and the iteration stops when the residual left,
max |n Δh(w) − w − ⟨n Δh(w) − w⟩|, is below ``tol`` (a length; the life loop states it
relative to R_q; without ``invariant`` the plain max |n Δh(w) − w|). The
rate must be a continuous function of the worn depth for the fixed point to exist: with the
tenfold step of the wear coefficient at the edge of solid contact a point at the edge has no
consistent depth and the residual stalls (``wear.solid_ramp_film``).

Accuracy control of the sub-block length: backward Euler's local error is estimated by half the
difference between it and the trapezoidal rule, e = (n/2) |Δh(w) − Δh(0)| (Hairer & Wanner,
*Solving ODEs II* §IV.8), over the intact columns less its mean, like the shape change of
:func:`~micropit_hpc.life.shape_change` (a uniform removal changes nothing the contact sees).
Units: SI (metres, cycles). No I/O, no MPI: the rate function does whatever communication it
needs, identically on every rank.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from micropit_hpc.spectral import rfft_plan

__all__ = ["ImplicitWear", "SpectralRelief", "backward_euler", "next_length"]

#: Past iterates the Anderson least-squares step combines.
MEMORY = 10

#: θ, the share of the elastic relief model that the preconditioner uses (module docstring;
#: measured in docs/life.md, "Implicit wear": 0.25 and above over-damp the running-in,
#: where a third of the contact is plastic and does not unload; 1 and above over-damp later).
RELIEF_SHARE = 0.1

#: Relative residual and the most iterations of the preconditioner's conjugate gradients.
CG_TOL, CG_MAX_ITER = 1e-3, 200


@dataclass(frozen=True)
class ImplicitWear:
    """A solved sub-block: the worn depths w_i [m] of both bodies over ``cycles`` load cycles,
    the wear rates per cycle at its start and end (:class:`~micropit_hpc.wear.WearRate` of the
    unworn and of the worn surfaces), the contact-only load cycles the solve took, the
    residual max |n Δh(w) − w| [m] of the depths returned (the iterate with the smallest
    residual when the tolerance was not met), whether it met the tolerance, and the residual
    of every iterate."""

    cycles: float
    depth: tuple[np.ndarray, ...]
    rate_start: tuple
    rate_end: tuple
    iterations: int
    residual: float
    converged: bool
    history: tuple[float, ...] = ()

    def error(self, intact: Sequence[np.ndarray]) -> tuple[float, ...]:
        """The local error estimate of each body [m]: (n/2) max |δ − ⟨δ⟩| over its ``intact``
        columns, δ = Δh(w) − Δh(0) (module docstring)."""
        out = []
        for a, b, keep in zip(self.rate_start, self.rate_end, intact, strict=True):
            d = (b.rate - a.rate)[keep]
            out.append(0.5 * self.cycles * float(np.abs(d - d.mean()).max()) if d.size else 0.0)
        return tuple(out)


class SpectralRelief:
    """The preconditioner M = I + θ n √D S √D of the implicit wear (module docstring) on a
    periodic grid of ``shape``: ``stiffness`` the half-spaces' Ŝ per mode of the real FFT
    (shape (nx, ny//2+1), 0 at the mean mode: a uniform wear relieves nothing), ``K0`` their
    cell self-compliance [m/Pa], with which :attr:`~micropit_hpc.wear.WearRate.relax` [1/cycle]
    gives D = ρ K₀ [m/(Pa cycle)], and ``share`` θ (None: :data:`RELIEF_SHARE`)."""

    def __init__(self, stiffness: np.ndarray, K0: float, shape: tuple[int, int],
                 share: float | None = None):
        self.stiffness, self.K0, self.shape = stiffness, float(K0), shape
        self.share = RELIEF_SHARE if share is None else float(share)
        # the cached pre-planned real FFT of the window, as the half-spaces' own response
        self._fft = rfft_plan(shape)
        self._transfer = self._fft.interleaved(stiffness)

    def _apply(self, d: np.ndarray, n: float, v: np.ndarray) -> np.ndarray:
        return v + n * d * self._fft.convolve(self._transfer, d * v)

    def solve(self, rates: Sequence, n: float) -> Callable[[tuple], tuple]:
        """M⁻¹ for a step of ``n`` cycles with the relief of ``rates`` (one
        :class:`~micropit_hpc.wear.WearRate` per body): a function of the residual maps."""
        roots = [np.sqrt(np.maximum(self.share * self.K0 * r.relax, 0.0)) for r in rates]

        def inverse(maps: tuple) -> tuple:
            return tuple(self._cg(d, n, f) if d.any() else f
                         for d, f in zip(roots, maps, strict=True))
        return inverse

    def _cg(self, d: np.ndarray, n: float, b: np.ndarray) -> np.ndarray:
        """Conjugate gradients on M z = b (M symmetric positive definite), from z = b."""
        norm = float(np.sqrt(np.vdot(b, b)))
        if norm == 0.0:
            return b
        z = b.copy()
        r = b - self._apply(d, n, z)
        p, rr = r.copy(), float(np.vdot(r, r))
        for _ in range(CG_MAX_ITER):
            if math.sqrt(rr) <= CG_TOL * norm:
                break
            q = self._apply(d, n, p)
            alpha = rr / float(np.vdot(p, q))
            z += alpha * p
            r -= alpha * q
            rr, last = float(np.vdot(r, r)), rr
            p = r + (rr / last) * p
        return z


def backward_euler(rates: Callable[[tuple[np.ndarray, ...]], tuple], start: tuple, n: float,
                   tol: float, max_iter: int = 60, memory: int | None = None,
                   errors: tuple[type[Exception], ...] = (),
                   relief: SpectralRelief | None = None,
                   guess: tuple[np.ndarray, ...] | None = None,
                   invariant: bool = False) -> ImplicitWear:
    """Solve w = n Δh(w) for both bodies (module docstring).

    ``rates(w)``: the wear rates per cycle (a :class:`~micropit_hpc.wear.WearRate` per body) of
    a contact-only load cycle on the surfaces worn by ``w`` (a tuple of depth maps);
    ``start``: the rates on the unworn surfaces (w = 0), already known from the sub-block's
    full load cycle; ``n``: the sub-block's cycles; ``tol``: the residual max |n Δh(w) − w|
    [m] to reach; ``max_iter``: the most contact-only cycles to spend; ``memory``: the past
    iterates Anderson combines (None: :data:`MEMORY`); ``errors``: exceptions of ``rates``
    that end the solve unconverged with the best iterate so far (an extrapolated iterate can
    be a surface whose contact does not converge; the caller shortens the step);
    ``relief``: the preconditioner (None: plain Anderson); ``guess``: the first iterate in
    place of the explicit n Δh(0) (the iteration goes on from it; measured: from the last
    step's depth it saves about half the iterations, though its residual can exceed |n Δh(0)|);
    ``invariant``: the rates are unchanged by a uniform wear of a body (a contact's are: the
    mean part is then solved exactly and ``tol`` bounds the residual less its mean, module
    docstring; False: the plain residual). Without wear (every rate zero) no contact is solved."""
    memory = MEMORY if memory is None else int(memory)
    shapes = [r.rate.shape for r in start]
    sizes = [int(np.prod(s)) for s in shapes]

    def pack(maps) -> np.ndarray:
        return np.concatenate([np.ravel(m) for m in maps])

    def unpack(x: np.ndarray) -> tuple[np.ndarray, ...]:
        out, k = [], 0
        for s, size in zip(shapes, sizes, strict=True):
            out.append(x[k:k + size].reshape(s))
            k += size
        return tuple(out)

    bounds = [int(k) for k in np.cumsum([0, *sizes])]

    def uniform(x: np.ndarray, f: np.ndarray) -> tuple[float, np.ndarray]:
        """The residual left once each body's worn depth is raised by the mean of its residual
        (no lower than its smallest depth allows: wear never adds material), and that shift:
        a uniform removal changes no rate, so it solves the mean part of w = n Δh(w) exactly."""
        shift = np.zeros_like(f)
        if not invariant:
            return float(np.abs(f).max()), shift
        for a, b in itertools.pairwise(bounds):
            shift[a:b] = max(float(f[a:b].mean()), -float(x[a:b].min()))
        return float(np.abs(f - shift).max()), shift

    g = n * pack([r.rate for r in start])                  # n Δh(0)
    if not g.any():
        zero = tuple(np.zeros(s) for s in shapes)
        return ImplicitWear(n, zero, tuple(start), tuple(start), 0, 0.0, True, (0.0,))
    x = np.zeros_like(g)
    f = g - x
    last = tuple(start)
    xs, fs = [], []          # iterates advanced by the preconditioned residual, and the latter
    it, (res, shift) = 0, uniform(x, f)
    history = [res]
    best = (res, x + shift, last)
    inverse = relief.solve(start, n) if relief is not None else None
    if guess is not None and res > tol and max_iter > 0:
        x_g = np.maximum(pack(guess), 0.0)
        it += 1
        try:
            last_g = tuple(rates(unpack(x_g)))
        except errors:
            history.append(math.inf)
        else:
            x, last = x_g, last_g
            f = n * pack([r.rate for r in last]) - x
            res, shift = uniform(x, f)
            history.append(res)
            if res < best[0]:
                best = (res, x + shift, last)
    while res > tol and it < max_iter:
        if inverse is not None:
            f = pack(inverse(unpack(f)))
        t = x + f                                         # x + M⁻¹ (n Δh(x) − x)
        xs.append(t)
        fs.append(f)
        if len(fs) > 1:
            dF = np.stack([fs[k + 1] - fs[k] for k in range(len(fs) - 1)], axis=1)
            dX = np.stack([xs[k + 1] - xs[k] for k in range(len(xs) - 1)], axis=1)
            gamma = np.linalg.lstsq(dF, fs[-1], rcond=None)[0]
            t = t - dX @ gamma
        del xs[:-memory - 1], fs[:-memory - 1]
        x = np.maximum(t, 0.0)                            # wear never adds material
        it += 1
        try:
            last = tuple(rates(unpack(x)))
        except errors:
            history.append(math.inf)
            break
        f = n * pack([r.rate for r in last]) - x
        res, shift = uniform(x, f)
        history.append(res)
        if res < best[0]:
            best = (res, x + shift, last)
    res, x, last = best                                   # the best iterate, if not converged
    return ImplicitWear(n, unpack(x), tuple(start), last, it, res,
                        res <= tol and history[-1] <= tol, tuple(history))


def next_length(n: float, error: float, tol: float, grow: float = 4.0,
                shrink: float = 0.2) -> float:
    """The next sub-block length from the last one's local error: n (0.9 tol/e)^{1/2} (the
    error of backward Euler is O(n²)), at most ``grow`` and at least ``shrink`` times n
    (Hairer, Nørsett & Wanner, *Solving ODEs I* §II.4)."""
    if error <= 0.0:
        return grow * n
    return n * min(grow, max(shrink, 0.9 * (tol / error) ** 0.5))
