"""Compiled stages of :mod:`micropit_hpc.lubrication.mixed` (Numba): the dispersion relation
(:func:`~micropit_hpc.lubrication.mixed.solve_dispersion`) one mode at a time, and the clipped
mean of :func:`~micropit_hpc.lubrication.mixed.restore_mean` in one pass (:func:`clipped_sum`).

The dispersion relation:

The same Newton iteration with continuation in c from the inviscid root ψ = a, the same stages
and the same equations per mode as the NumPy reference, with two differences in where it
stops and two in how it computes:

* a mode leaves the last stage's Newton loop as soon as its step is at most ``tol`` of |ψ|
  (quadratic convergence then leaves an error of the order of ``tol``² relative, below
  round-off), where the reference runs every mode through all ``newton`` steps of every stage;
* it leaves an earlier stage once its step is at most ``tol_stage`` of |ψ|: an earlier stage's
  root is only the next stage's starting point, which Newton's method then refines anyway;
* 1/z for the denominators 1 + eΩ (Re ≥ 1) and F' is conj(z)/|z|² (a few ulps, as the
  library's quotient), falling back to the quotient where |z|² under- or overflows;
* Ω = √(ψ² + k_y²) by the half-angle formula (:func:`_sqrt`) instead of the library's
  complex square root, 10 % of the time; the final residual uses the library's.

On gear-like numbers a mode takes 27–31 Newton steps in all (9 where the film is inviscid)
instead of 64, in one pass per mode instead of some twenty passes over the spectrum per step,
and ψ agrees with the reference to 2.5 ulps of max(|ψ|, |a|) (tests/test_mixed.py holds it to
64; times in docs/performance.md §11). ``parallel=False``: every core already runs an MPI
rank. ``cache=True``: compiled once per machine (``__pycache__`` or ``NUMBA_CACHE_DIR``).
"""

from __future__ import annotations

import cmath
import math

from numba import njit


@njit(cache=True, inline="always")
def _times_recip(w, z):
    """w/z as w·conj(z)/|z|², or the quotient where |z|² is zero or not finite."""
    d = z.real * z.real + z.imag * z.imag
    if d == 0.0 or not math.isfinite(d):
        return w / z
    return w * complex(z.real / d, -z.imag / d)


@njit(cache=True, inline="always")
def _abs2(z):
    """|z|²."""
    return z.real * z.real + z.imag * z.imag


@njit(cache=True, inline="always")
def _sqrt(z):
    """The principal square root (Re ≥ 0; the imaginary part takes the sign of Im z, −0
    included, as the library's), by t = √((|z| + |Re z|)/2); |z| from hypot."""
    x, y = z.real, z.imag
    if x == 0.0 and y == 0.0:
        return complex(0.0, y)
    t = math.sqrt(0.5 * (math.hypot(x, y) + abs(x)))
    if x >= 0.0:
        return complex(t, 0.5 * y / t)
    return complex(0.5 * abs(y) / t, math.copysign(t, y))


@njit(cache=True)
def dispersion(a, ky2, c, e, eta_x, eta_y, stages, newton, tol, tol_stage, psi):
    """ψ of every mode (flattened arrays: ``a`` complex, ``ky2`` = k_y², ``psi`` the output)
    through the continuation ``stages`` (the factors s of c, increasing to 1). Returns (the
    largest relative residual |F|/max(|ψ|, |a|), the Newton steps taken over all modes)."""
    worst = 0.0
    steps = 0
    last = stages.size - 1
    for i in range(a.size):
        ai = a[i]
        k2 = ky2[i]
        p = ai
        for si in range(stages.size):
            cs = c * stages[si]
            stop = tol if si == last else tol_stage
            for _ in range(newton):
                p2 = p * p
                omega = _sqrt(p2 + k2)
                if omega == 0:
                    omega = 1e-300 + 0j
                flux = p2 / eta_x + k2 / eta_y
                den = 1.0 + e * omega
                F = p - ai - _times_recip(1j * cs * omega * flux, den)
                d_omega = p / omega
                dF = 1.0 - _times_recip(1j * cs * ((d_omega * flux + omega * 2 * p / eta_x) * den
                                                   - omega * flux * e * d_omega), den * den)
                step = _times_recip(F, dF)
                p = p - step
                steps += 1
                if _abs2(step) <= stop * stop * _abs2(p):
                    break
        psi[i] = p
        omega = cmath.sqrt(p * p + k2)
        F = p - ai - 1j * c * omega * (p * p / eta_x + k2 / eta_y) / (1.0 + e * omega)
        r = abs(F) / (max(abs(p), abs(ai)) + 1e-300)
        if r > worst:
            worst = r
    return worst, steps


@njit(cache=True, fastmath={"reassoc", "nsz"})
def clipped_sum(p, c, p_lim):
    """(Σ clip(p + c, 0, p_lim), the number of points with 0 < clip(p + c, 0, p_lim) < p_lim)
    over the flat array ``p``: one pass of :func:`~micropit_hpc.lubrication.mixed.restore_mean`'s
    mean and Newton slope, where NumPy makes four to seven. Each term is NumPy's
    ``maximum(minimum(p + c, p_lim), 0)`` (a NaN stays NaN); the terms are added in vector
    lanes (``reassoc``), another order than NumPy's pairwise sum, but a fixed one, so the sum is
    still a non-decreasing function of c (each term is, and rounding is monotone)."""
    s = 0.0
    n = 0
    for i in range(p.size):
        v = p[i] + c
        v = p_lim if v > p_lim else v
        v = 0.0 if v < 0.0 else v
        s += v
        n += (v > 0.0) & (v < p_lim)
    return s, n
