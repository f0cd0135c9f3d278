"""Smooth (Hertz) contact of two elastic bodies: line contact and elliptical point contact.

Conventions (docs/model.md §1, §2.2): 2/E' = (1-ν1²)/E1 + (1-ν2²)/E2 and E* = E'/2; pressure is
positive in compression; x is the rolling direction, y across it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipe, ellipkm1


def reduced_modulus(E1: float, nu1: float, E2: float, nu2: float) -> float:
    """E' from 2/E' = (1-ν1²)/E1 + (1-ν2²)/E2 (docs/model.md §1). E* = E'/2."""
    return 2.0 / ((1.0 - nu1**2) / E1 + (1.0 - nu2**2) / E2)


def line_contact(w, R, E_star):
    """Hertz line contact: semi-width b and peak pressure p0 (docs/model.md §2.2).

    b = √(4 w R / (π E*)),  p0 = 2 w / (π b) = √(w E* / (π R)).

    ``w`` is the load per unit length [N/m], ``R`` the reduced radius [m], ``E_star`` [Pa].
    Vectorised; a zero load gives b = p0 = 0. Source: Johnson, Contact Mechanics (1985) eq. 4.45.
    """
    w, R = np.asarray(w, dtype=float), np.asarray(R, dtype=float)
    b = np.sqrt(4.0 * w * R / (math.pi * E_star))
    p0 = np.sqrt(w * E_star / (math.pi * R))
    return b, p0


@dataclass(frozen=True)
class EllipticalHertz:
    """Hertz elliptical contact: semi-axes along x (rolling) and y, peak pressure, total load."""

    ax: float
    ay: float
    p0: float
    load: float


_SERIES_M = 1e-3
_C = [(math.comb(2 * n, n) / 4.0**n) ** 2 for n in range(8)]  # K = π/2 Σ c_n m^n
_D = [c / (1 - 2 * n) for n, c in enumerate(_C)]              # E = π/2 Σ d_n m^n


def _elliptic_differences(s: float) -> tuple[float, float]:
    """(K - E)/m and (E/(1-m) - K)/m for an ellipse of axis ratio s = b/a, m = e² = 1 - s²: the
    two differences in the Hertz ellipse relations. Both cancel as m -> 0, so small m uses their
    power series (Abramowitz & Stegun 17.3.11-12; truncation below 1e-18); long ellipses
    (m -> 1) take K from ``ellipkm1(s²)``, which keeps its accuracy there."""
    m = (1.0 - s) * (1.0 + s)
    if m >= _SERIES_M:
        K, E = ellipkm1(s * s), ellipe(m)
        return (K - E) / m, (E / (s * s) - K) / m
    k_minus_e = sum((c - d) * m ** (n - 1)
                    for n, (c, d) in enumerate(zip(_C, _D, strict=True)) if n)
    e_over = 0.0
    cumulative = 0.0
    for n, (c, d) in enumerate(zip(_C, _D, strict=True)):
        cumulative += d  # E/(1-m) = π/2 Σ_n m^n Σ_{j≤n} d_j
        if n:
            e_over += (cumulative - c) * m ** (n - 1)
    return math.pi / 2 * k_minus_e, math.pi / 2 * e_over


def _curvature_ratio(s: float) -> float:
    """B/A of an ellipse of axis ratio s = b/a ≤ 1: [E/s² - K] / [K - E] (Johnson eq. 3.64)."""
    k_minus_e, e_over = _elliptic_differences(s)
    return e_over / k_minus_e


def elliptical_contact(Rx: float, Ry: float, E_star: float, *, load: float | None = None,
                       p0: float | None = None) -> EllipticalHertz:
    """Hertz contact of two bodies with reduced radii Rx, Ry, given either the load or p0.

    With a ≥ b the semi-axes, e² = 1 - b²/a², K, E the complete elliptic integrals and
    A ≤ B the relative curvatures 1/(2R) (B along the minor axis b), Johnson (Contact Mechanics,
    1985, eqs. 3.64) gives
        A = p0 b (K - E) / (E* e² a²),   B = p0 b [(a²/b²) E - K] / (E* e² a²),
    so B/A fixes e, then a³ = 3F (K - E) / (2π E* e² A) for a given load F, or
    a = p0 √(1-e²) (K - E) / (E* e² A) for a given p0; F = (2π/3) a b p0.
    The circular limit (Rx = Ry = R) is a = (3FR/(4E*))^{1/3}.
    """
    if (load is None) == (p0 is None):
        raise ValueError("give exactly one of load and p0")
    Ax, Ay = 1.0 / (2.0 * Rx), 1.0 / (2.0 * Ry)
    A, B = min(Ax, Ay), max(Ax, Ay)
    ratio = B / A
    if ratio == 1.0:  # circle: (K - E)/e² -> π/4, b/a = 1
        g, s = math.pi / 4.0, 1.0
    else:  # B/A falls monotonically from ∞ (s -> 0) to 1 (s = 1); solve for ln s
        lo = -1.0
        while _curvature_ratio(math.exp(lo)) < ratio:
            lo *= 2.0
            if lo < -300.0:
                raise ValueError(f"curvature ratio {ratio:g}: practically a line contact")
        t = brentq(lambda q: _curvature_ratio(math.exp(q)) - ratio, lo, 0.0, xtol=1e-15,
                   rtol=1e-15)
        s = math.exp(t)
        g = _elliptic_differences(s)[0]
    if load is not None:
        a = (3.0 * load * g / (2.0 * math.pi * E_star * A)) ** (1.0 / 3.0)
        b = a * s
        p = 3.0 * load / (2.0 * math.pi * a * b) if load > 0 else 0.0
        F = load
    else:
        a = p0 * s * g / (E_star * A)
        b = a * s
        p, F = p0, 2.0 * math.pi * a * b * p0 / 3.0
    # the minor axis b lies along the direction of larger curvature (smaller radius)
    ax, ay = (b, a) if Ax >= Ay else (a, b)
    return EllipticalHertz(ax=ax, ay=ay, p0=p, load=F)
