"""Film-thickness formulas and Λ (docs/model.md §2.4); Table 3's h_c column is in test_gear.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from micropit_hpc import film


def test_dh61_by_hand_at_the_paper_pitch_point():
    """R = 9.978 mm, ū = 2 m/s, w = 174 391 N/m, E' = 230.77 GPa, η0 = 90 mPa s, α = 21/GPa:
    U = 7.816e-11, G = 4846, W = 7.573e-5 -> 1.6 R G^0.6 U^0.7 W^-0.13 = 0.7503 µm."""
    hc = film.dowson_higginson_1961(9.978e-3, 2.0, 174391.0, 230.77e9, 0.09, 21e-9)
    assert float(hc) == pytest.approx(0.7503e-6, rel=2e-4)


def test_dh66_and_dh61_differ_by_the_known_factor():
    """DH66/DH61 = (2.65/1.6) G^-0.06 U^0: the two differ only in their G exponent (0.54 vs
    0.6) and constant; U and W enter with the same powers."""
    G = 21e-9 * 230.77e9
    for u, w in ((2.0, 1.7e5), (0.5, 3e4)):
        args = (0.01, u, w, 230.77e9, 0.09, 21e-9)
        ratio = film.dowson_higginson_1966(*args) / film.dowson_higginson_1961(*args)
        assert float(ratio) == pytest.approx(2.65 / 1.6 * G**-0.06, rel=1e-12)


def test_hamrock_dowson_circular_point_contact_by_hand():
    """R_x = R_y = 10 mm, ū = 1 m/s, F = 100 N: k = 1.0339, h_c = 2.69 R U^0.67 G^0.53
    W^-0.067 (1 - 0.61 e^-0.73k)."""
    Ep, eta, alpha = 230.77e9, 0.05, 20e-9
    U, G, W = eta * 1.0 / (Ep * 0.01), alpha * Ep, 100.0 / (Ep * 1e-4)
    k = 1.0339
    expected = 2.69 * 0.01 * U**0.67 * G**0.53 * W**-0.067 * (1 - 0.61 * math.exp(-0.73 * k))
    got = film.hamrock_dowson_1977(0.01, 0.01, 1.0, 100.0, Ep, eta, alpha)
    assert float(got) == pytest.approx(expected, rel=1e-12)
    assert 0.1e-6 < expected < 1e-6  # a plausible film, guards the exponents' signs
    # an elliptical contact, R_y = 4 R_x: k = 1.0339·4^0.636 = 2.4968 (major axis across
    # rolling), which thickens the film; the swapped orientation (R_y = R_x/4) thins it
    k4 = 1.0339 * 4**0.636
    assert k4 == pytest.approx(2.4968, abs=1e-4)
    wide = film.hamrock_dowson_1977(0.01, 0.04, 1.0, 100.0, Ep, eta, alpha)
    assert float(wide) == pytest.approx(
        expected * (1 - 0.61 * math.exp(-0.73 * k4)) / (1 - 0.61 * math.exp(-0.73 * k)),
        rel=1e-12)
    narrow = film.hamrock_dowson_1977(0.01, 0.0025, 1.0, 100.0, Ep, eta, alpha)
    assert float(narrow) < float(got) < float(wide)


def test_thermal_factor_limits_and_a_hand_value():
    assert float(film.thermal_factor_wilson_sheu(0.3, 2.0, 0.09, 0.03, 1e12)) == pytest.approx(
        1.0, abs=1e-5)
    # S = 0.2 (Z = 0.1), L = 0.09·0.03·4/0.13 = 0.08308
    L = 0.09 * 0.03 * 4 / 0.13
    hand = 1 / (1 + 0.241 * (1 + 14.8 * 0.1**0.83) * L**0.64)
    assert float(film.thermal_factor_wilson_sheu(-0.2, 2.0, 0.09, 0.03, 0.13)) == pytest.approx(
        hand, rel=1e-12)
    phi = film.thermal_factor_wilson_sheu(np.array([0.0, 0.2, 0.8]), 2.0, 0.09, 0.03, 0.13)
    assert np.all(np.diff(phi) < 0) and np.all(phi < 1)  # more sliding, more heating


def test_lambda_uses_the_composite_roughness():
    assert film.composite_rq(3e-6, 4e-6) == pytest.approx(5e-6)
    assert float(film.specific_film_thickness(1e-6, 5e-6)) == pytest.approx(0.2)
    assert np.isinf(film.specific_film_thickness(1e-6, 0.0))


def test_iso_lambda_gf_divides_by_the_mean_arithmetic_roughness():
    """ISO/TS 6336-22 Method B: λ_GF = h / ½(R_a1 + R_a2); smooth flanks give infinity."""
    assert film.iso_lambda_gf(0.6e-6, 0.4e-6, 0.8e-6) == pytest.approx(1.0)
    assert np.all(np.isinf(film.iso_lambda_gf(np.array([1e-6, 2e-6]), 0.0, 0.0)))


def test_ra_of_a_gaussian_field_is_sqrt_2_over_pi_of_rq():
    from micropit_hpc.spectral import Grid
    from micropit_hpc.surfaces import gaussian_surface
    t = gaussian_surface(Grid(256, 256, 1e-3, 1e-3), 1e-6, 20e-6, 20e-6, 3)
    assert t.ra == pytest.approx(math.sqrt(2 / math.pi) * t.rq, rel=0.02)
