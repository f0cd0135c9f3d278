"""Hertz line and elliptical contact against closed forms (docs/model.md §2.2, §2.3)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from micropit_hpc.hertz import elliptical_contact, line_contact, reduced_modulus

E_STEEL = reduced_modulus(210e9, 0.3, 210e9, 0.3) / 2


def test_reduced_modulus_of_steel_on_steel():
    assert reduced_modulus(210e9, 0.3, 210e9, 0.3) == pytest.approx(230.769e9, rel=1e-5)
    # a rigid counterface leaves only body 1's compliance
    assert reduced_modulus(200e9, 0.25, 1e30, 0.3) == pytest.approx(2 * 200e9 / (1 - 0.25**2))


def test_line_contact_carries_its_load():
    """∫ p0 √(1 - x²/b²) dx over [-b, b] = π b p0 / 2 = w."""
    w = np.array([1e4, 1.7e5, 3e5])
    b, p0 = line_contact(w, 0.01, E_STEEL)
    for bi, pi, wi in zip(b, p0, w, strict=True):
        integral = quad(lambda x, bi=bi, pi=pi: pi * math.sqrt(1 - (x / bi) ** 2), -bi, bi)[0]
        assert integral == pytest.approx(wi, rel=1e-9)
    np.testing.assert_allclose(math.pi * b * p0 / 2, w, rtol=1e-14)
    assert line_contact(0.0, 0.01, E_STEEL) == (0.0, 0.0)


def test_circular_limit_is_the_sphere_solution():
    R, F = 0.01, 50.0
    h = elliptical_contact(R, R, E_STEEL, load=F)
    a = (3 * F * R / (4 * E_STEEL)) ** (1 / 3)
    assert h.ax == pytest.approx(a, rel=1e-12) and h.ay == pytest.approx(a, rel=1e-12)
    assert h.p0 == pytest.approx(3 * F / (2 * math.pi * a**2), rel=1e-12)


@pytest.mark.parametrize("ratio", [1.0 + 1e-9, 1.0 + 1e-6, 1.5, 4.0, 20.0, 200.0])
def test_elliptical_load_and_pressure_are_consistent_both_ways(ratio):
    Rx, Ry = 5e-3, 5e-3 * ratio
    h = elliptical_contact(Rx, Ry, E_STEEL, load=120.0)
    assert h.load == pytest.approx(2 * math.pi * h.ax * h.ay * h.p0 / 3, rel=1e-12)
    back = elliptical_contact(Rx, Ry, E_STEEL, p0=h.p0)
    assert back.load == pytest.approx(120.0, rel=1e-9)
    assert back.ax == pytest.approx(h.ax, rel=1e-9) and back.ay == pytest.approx(h.ay, rel=1e-9)


def test_ellipse_with_axis_ratio_two_from_tabulated_elliptic_integrals():
    """b/a = 1/2, e² = 3/4: K = 2.156516, E = 1.211056 (Abramowitz & Stegun table 17.1), so
    R_y/R_x = B/A = (4E - K)/(K - E) = 2.842771 must give a_y/a_x = 2."""
    K, E = 2.1565156475, 1.2110560276
    h = elliptical_contact(1e-2, 1e-2 * (4 * E - K) / (K - E), E_STEEL, load=10.0)
    assert h.ay / h.ax == pytest.approx(2.0, rel=1e-9)


def test_nearly_circular_contact_is_continuous():
    base = elliptical_contact(1e-2, 1e-2, E_STEEL, load=10.0)
    for eps in (1e-12, 1e-8, 1e-5, 1e-3):
        h = elliptical_contact(1e-2, 1e-2 * (1 + eps), E_STEEL, load=10.0)
        assert h.p0 == pytest.approx(base.p0, rel=2 * eps)
        # B/A - 1 = 3e²/4 + O(e⁴) and a/b - 1 = e²/2 + O(e⁴): a_y/a_x - 1 = (2/3)(R_y/R_x - 1)
        assert h.ay / h.ax - 1 == pytest.approx(2 * eps / 3, rel=0.01)


@pytest.mark.parametrize("ratio", [1.5, 3.0, 6.0, 10.0])
def test_ellipticity_matches_hamrock_brewe(ratio):
    """k = a_y/a_x ≈ 1.0339 (R_y/R_x)^0.636 (Hamrock & Brewe 1983: their fit is within 3 % for
    1 ≤ R_y/R_x ≤ 10; it drifts beyond, 3.0 % at 50), and the
    major axis lies along the larger radius (swapping the radii swaps the axes)."""
    h = elliptical_contact(4e-3, 4e-3 * ratio, E_STEEL, load=100.0)
    assert h.ay / h.ax == pytest.approx(1.0339 * ratio**0.636, rel=0.03)
    swapped = elliptical_contact(4e-3 * ratio, 4e-3, E_STEEL, load=100.0)
    assert swapped.ax == pytest.approx(h.ay, rel=1e-12)
    assert swapped.ay == pytest.approx(h.ax, rel=1e-12)


def test_long_ellipse_approaches_line_contact_pressure():
    """A very elongated ellipse tends to the line contact of the same p0, b = 2 R_x p0 / E*
    (the gap closes like R_x/R_y: 4.6e-4 at R_y/R_x = 1e3, 4.6e-6 at 1e5)."""
    Rx = 5e-3
    for ratio, gap in ((1e3, 5e-4), (1e5, 5e-6), (1e9, 1e-9), (1e14, 1e-13)):
        h = elliptical_contact(Rx, Rx * ratio, E_STEEL, p0=1.1e9)
        assert h.ax == pytest.approx(2 * Rx * 1.1e9 / E_STEEL, rel=gap)
