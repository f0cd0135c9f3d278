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
iterates (a GMRES on the linearised problem), converges on it. A diagonal preconditioner from
the cell-local relief rate ρ (:attr:`~micropit_hpc.wear.WearRate.relax`) was measured to slow it:
it over-damps the spot-scale and plastic modes (docs/life.md, "Implicit wear"). Worn depths
never go negative (the iterate is clipped at 0). The iteration stops when the residual
max |n Δh(w) − w| is below ``tol`` (a length; the life loop states it relative to R_q). The
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

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["ImplicitWear", "backward_euler", "next_length"]

#: Past iterates the Anderson least-squares step combines.
MEMORY = 10


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


def backward_euler(rates: Callable[[tuple[np.ndarray, ...]], tuple], start: tuple, n: float,
                   tol: float, max_iter: int = 60, memory: int = MEMORY,
                   errors: tuple[type[Exception], ...] = ()) -> ImplicitWear:
    """Solve w = n Δh(w) for both bodies (module docstring).

    ``rates(w)``: the wear rates per cycle (a :class:`~micropit_hpc.wear.WearRate` per body) of
    a contact-only load cycle on the surfaces worn by ``w`` (a tuple of depth maps);
    ``start``: the rates on the unworn surfaces (w = 0), already known from the sub-block's
    full load cycle; ``n``: the sub-block's cycles; ``tol``: the residual max |n Δh(w) − w|
    [m] to reach; ``max_iter``: the most contact-only cycles to spend; ``errors``: exceptions
    of ``rates`` that end the solve unconverged with the best iterate so far (an extrapolated
    iterate can be a surface whose contact does not converge; the caller shortens the step).
    Without wear (every rate zero) no contact is solved."""
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

    g = n * pack([r.rate for r in start])                  # n Δh(0)
    if not g.any():
        zero = tuple(np.zeros(s) for s in shapes)
        return ImplicitWear(n, zero, tuple(start), tuple(start), 0, 0.0, True, (0.0,))
    x = np.zeros_like(g)
    f = g - x
    last = tuple(start)
    xs, fs = [], []          # values n Δh(x) of the map and residuals
    it, res = 0, float(np.abs(f).max())
    history = [res]
    best = (res, x, last)
    while res > tol and it < max_iter:
        t = x + f                                         # n Δh(x)
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
        res = float(np.abs(f).max())
        history.append(res)
        if res < best[0]:
            best = (res, x, last)
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
